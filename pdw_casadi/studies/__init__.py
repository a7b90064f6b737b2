"""Layer 6, studies built on the fit: the fit workflow, the prosthesis design and subject
scaling."""

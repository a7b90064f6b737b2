"""Layer 6, studies built on the fit: the prosthesis design and subject scaling."""

"""The toolkit's version (one place: the package, its commands and pyproject.toml agree)."""

__version__ = "0.1.0"

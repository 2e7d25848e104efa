"""The package's version, in the lowest layer: what the eigen cache keys on and the
command line reports, readable without importing every stage."""

VERSION = "0.1.0.dev0"
__version__ = VERSION

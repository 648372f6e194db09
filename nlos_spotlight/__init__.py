"""nlos-spotlight: spotlight placement, light transport and learning for NLOS human localization."""

__version__ = "0.1.0"

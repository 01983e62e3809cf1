"""ballchain: event-driven 3D simulation of a falling ball chain (Itano & Sugihara-Seki)."""

__version__ = "0.1.0"

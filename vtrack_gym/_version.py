"""The package version, single source: ``pyproject.toml`` reads it (a leaf module: any layer may import it)."""

__version__ = "0.3.0.dev0"

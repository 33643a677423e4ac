"""The scripts of docs/measurements/ as modules, for the tests (they are in no package)."""

import importlib.util
import sys
from pathlib import Path

MEASUREMENTS = Path(__file__).resolve().parents[1] / "docs" / "measurements"


def measurement(name: str):
    """The script docs/measurements/NAME.py as a module (what ``python`` runs of it, less main)."""
    key = f"measurements_{name}"
    if key not in sys.modules:
        spec = importlib.util.spec_from_file_location(key, MEASUREMENTS / f"{name}.py")
        module = importlib.util.module_from_spec(spec)
        sys.modules[key] = module  # before running it: dataclasses look their module up
        spec.loader.exec_module(module)
    return sys.modules[key]

"""One of scripts/' extensionless Python scripts (seed-matrix, mfot-run) loaded as a module, for the tests that
call its functions directly: an extensionless file is not found by import, so it is loaded from its path."""

from __future__ import annotations

import importlib.machinery
import importlib.util
from pathlib import Path
from types import ModuleType


def load_script(path: Path, name: str) -> ModuleType:
    """The script at path, executed as a module called name (its main() guard keeps it from running)."""
    loader = importlib.machinery.SourceFileLoader(name, str(path))
    spec = importlib.util.spec_from_loader(name, loader)
    module = importlib.util.module_from_spec(spec)
    loader.exec_module(module)
    return module

"""The layering: the library (neuroslam outside neuroslam.lab) imports neither the simulator nor the glue's
packages, the simulator never imports neuroslam, and no private name crosses a module boundary.

``lint-imports`` (run by .ci/run) checks the contracts declared in pyproject.toml; these tests check that
the declaration covers every module and that it fails when the rule is broken.
"""

from __future__ import annotations

import ast
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
GLUE = "lab"


def _contracts() -> list[dict]:
    return tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["importlinter"]["contracts"]


def _python_files(package: str) -> list[Path]:
    return sorted((ROOT / package).rglob("*.py"))


def _module_name(path: Path) -> str:
    parts = path.relative_to(ROOT).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def test_the_library_contract_names_every_module_outside_the_glue():
    library = next(c for c in _contracts() if "neuroslam.lab" in c["forbidden_modules"])
    children = {f"neuroslam.{path.stem}" for path in (ROOT / "neuroslam").iterdir()
                if (path.suffix == ".py" and path.stem != "__init__") or (path / "__init__.py").is_file()}
    assert set(library["source_modules"]) == children - {f"neuroslam.{GLUE}"}
    assert {"sim", "mujoco", "gymnasium", "rerun", "ray", "matplotlib"} <= set(library["forbidden_modules"])


def test_the_package_root_imports_only_the_library():
    tree = ast.parse((ROOT / "neuroslam" / "__init__.py").read_text())
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            assert node.level == 1 and not (node.module or "").startswith(GLUE), ast.unparse(node)
        elif isinstance(node, ast.Import):
            pytest.fail(f"neuroslam/__init__.py: {ast.unparse(node)}")


@pytest.mark.parametrize("package", ["neuroslam", "sim"])
def test_no_private_name_crosses_a_module_boundary(package):
    crossings = []
    for path in _python_files(package):
        tree = ast.parse(path.read_text())
        imported_modules = set()
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom):
                for alias in node.names:
                    if alias.name.startswith("_") and not alias.name.startswith("__"):
                        crossings.append(f"{_module_name(path)}: {ast.unparse(node)}")
                    imported_modules.add(alias.asname or alias.name)
            elif isinstance(node, ast.Import):
                imported_modules.update((alias.asname or alias.name).split(".")[0] for alias in node.names)
        for node in ast.walk(tree):  # module._name
            if (isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name)
                    and node.value.id in imported_modules and node.attr.startswith("_")
                    and not node.attr.startswith("__")):
                crossings.append(f"{_module_name(path)}: {ast.unparse(node)}")
    assert crossings == []


def test_the_contract_breaks_when_a_library_module_imports_the_simulator(tmp_path):
    linter = shutil.which("lint-imports", path=str(Path(sys.executable).parent))
    if linter is None:
        pytest.skip("import-linter is not installed (pip install '.[test]')")
    for package in ("neuroslam", "sim"):
        shutil.copytree(ROOT / package, tmp_path / package, ignore=shutil.ignore_patterns("__pycache__"))
    shutil.copy(ROOT / "pyproject.toml", tmp_path)
    kept = subprocess.run([linter], cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert kept.returncode == 0, kept.stdout + kept.stderr
    with open(tmp_path / "neuroslam" / "vision" / "preprocessing.py", "a") as file:
        file.write("\n\ndef _inside_a_function():\n    import sim  # noqa: F401\n")
    broken = subprocess.run([linter], cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert broken.returncode != 0
    assert "neuroslam.vision is not allowed to import sim" in broken.stdout

"""The packages import one way (docs/architecture.md): the contract imports
no other part of the model, the physics not the radar, the model nothing of
the gateware, the gateware nothing of the command line."""

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

#: package folder -> prefixes of rast modules it must not import
FORBIDDEN = {
    "model/contract": ("rast.model.physics", "rast.model.radar", "rast.model.files", "rast.hdl", "rast.gateware",
                       "rast.sim", "rast.cli"),
    "model/physics": ("rast.model.radar", "rast.hdl", "rast.gateware", "rast.sim", "rast.cli"),
    "model/radar": ("rast.hdl", "rast.gateware", "rast.sim", "rast.cli"),
    "model/files": ("rast.model.radar", "rast.hdl", "rast.gateware", "rast.sim", "rast.cli"),
    "hdl": ("rast.gateware", "rast.sim", "rast.cli", "rast.model.physics", "rast.model.radar"),
}


def imports_of(path: Path) -> set[str]:
    tree = ast.parse(path.read_text(), str(path))
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names |= {a.name for a in node.names}
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names.add(node.module)
    return names


@pytest.mark.parametrize("folder", sorted(FORBIDDEN))
def test_imports_point_one_way(folder):
    files = sorted((ROOT / folder).rglob("*.py"))
    assert files
    wrong = [(f.relative_to(ROOT).as_posix(), name) for f in files for name in sorted(imports_of(f))
             if name.startswith(FORBIDDEN[folder])]
    assert wrong == []


def test_the_page_names_every_folder():
    page = (ROOT / "docs" / "architecture.md").read_text()
    for folder in ("model/contract/", "model/physics/", "model/radar/", "model/files/", "hdl/", "gateware/",
                   "sim/", "rast/", "tests/", "bench/"):
        assert f"`{folder}`" in page, folder

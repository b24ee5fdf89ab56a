"""docs/architecture.md is the project's architecture page: code and docs point to it, and its
layer table follows the import-linter contract."""

import re
import tomllib
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
PAGE = REPO / "docs" / "architecture.md"
OLD_NAME = "DESIGN" + ".md"  # a page that is not in the repository


def test_code_and_docs_cite_the_architecture_page_not_a_missing_one():
    files = [*REPO.glob("tactile_bt/**/*.py"), *REPO.glob("tests/*.py"), *REPO.glob("docs/*.md"),
             *REPO.glob("examples/**/*.py"), REPO / "README.md", REPO / "sim" / "README.md"]
    citing = [str(f.relative_to(REPO)) for f in files if OLD_NAME in f.read_text(encoding="utf-8")]
    assert citing == []
    assert "docs/architecture.md" in (REPO / "README.md").read_text(encoding="utf-8")


def test_the_page_has_the_cycle_the_layers_the_conventions_and_the_extension_points():
    headings = re.findall(r"^#+ (.+)$", PAGE.read_text(encoding="utf-8"), flags=re.M)
    for wanted in ("One control cycle", "Layers", "Conventions", "Extension points"):
        assert any(h.startswith(wanted) for h in headings), (wanted, headings)


def test_the_layer_table_names_every_layer_of_the_contract():
    config = tomllib.loads((REPO / "pyproject.toml").read_text(encoding="utf-8"))
    contract = next(c for c in config["tool"]["importlinter"]["contracts"] if c["type"] == "layers")
    text = PAGE.read_text(encoding="utf-8")
    for layer in contract["layers"]:
        for module in layer.split("|"):
            name = module.strip().removeprefix("tactile_bt.")
            assert f"`{name}/`" in text or f"`{name}`" in text, name

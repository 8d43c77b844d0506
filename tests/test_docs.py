"""The documentation in the repo: every spec key and every condition id is documented there."""

from __future__ import annotations

import re
import tomllib
from pathlib import Path

from glocal_verify.conditions.registry import CATALOGUE
from glocal_verify.results import ALIASES
from glocal_verify.spec.reference import KEYS, generate, schema_keys

ROOT = Path(__file__).resolve().parent.parent
DOCS = ROOT / "docs"
LINK = re.compile(r"\]\(([^)\s]+)\)")


def _doc_files() -> list[Path]:
    return sorted(DOCS.glob("*.md")) + [ROOT / "README.md"]


def test_every_spec_schema_property_has_a_description() -> None:
    missing = [path for path, sub, _ in schema_keys() if not str(sub.get("description", "")).strip()]
    assert not missing, missing


def test_every_spec_schema_key_has_a_default_and_a_toml_example() -> None:
    paths = [path for path, _, _ in schema_keys()]
    assert set(paths) == set(KEYS)
    for path in paths:
        default, example = KEYS[path]
        assert default.strip(), path
        tomllib.loads(example)  # every example is valid TOML


def test_docs_spec_md_is_up_to_date_with_the_generator() -> None:
    text = (DOCS / "spec.md").read_text(encoding="utf-8")
    assert text == generate(), "regenerate: python -m glocal_verify.spec.reference > docs/spec.md"


def test_every_catalogue_id_and_alias_has_a_section_in_docs_conditions_md() -> None:
    text = (DOCS / "conditions.md").read_text(encoding="utf-8")
    headings = set(re.findall(r"^### `([^`]+)`", text, flags=re.M))
    assert set(CATALOGUE) <= headings, set(CATALOGUE) - headings
    assert set(ALIASES) <= headings


def test_the_polarity_table_of_docs_conditions_md_matches_the_catalogue() -> None:
    text = (DOCS / "conditions.md").read_text(encoding="utf-8")
    rows = {m[0]: (m[1], m[2]) for m in re.findall(r"^\| `([^`]+)` \| [^|]+ \| `(holds|fails)` \| (yes|no) \|$", text, flags=re.M)}
    assert set(rows) == set(CATALOGUE)
    for cid, info in CATALOGUE.items():
        assert rows[cid] == (info.favourable.value, "yes" if info.margin_is_distance else "no"), cid


def test_no_doc_links_outside_the_repo() -> None:
    for doc in _doc_files():
        text = doc.read_text(encoding="utf-8")
        assert "../shared" not in text and "CONDITIONS.md" not in text, doc
        for target in LINK.findall(text):
            if re.match(r"^[a-z]+:", target) or target.startswith("#"):
                continue
            resolved = (doc.parent / target.split("#")[0]).resolve()
            assert resolved.is_relative_to(ROOT), f"{doc.name}: {target}"
            assert resolved.exists(), f"{doc.name}: {target} does not exist"

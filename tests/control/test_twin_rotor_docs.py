"""docs/twin_rotor.md shows what benchmarks/twin_rotor_docs.py computes from the code as it is.

The script records its numbers in docs/twin_rotor_numbers.json and renders the doc's
generated blocks from them. Here every block must be the rendering of that file, and
the file must hold what the code computes now: in full for the rig, the control design
and both closed-loop experiments (shared with tests/test_control.py), and for seed 0 of
the rig without Coulomb friction in the seed study (shared with tests/test_twin_rotor.py).
Numbers are compared as the doc prints them, so round-off below the printed digits
cannot fail the check, and any printed digit that changes does.
"""

from __future__ import annotations

import json

import pytest

from conftest import REPO

DOC = REPO / "docs" / "twin_rotor.md"
NUMBERS = REPO / "docs" / "twin_rotor_numbers.json"


@pytest.fixture(scope="module")
def recorded():
    return json.loads(NUMBERS.read_text())


def test_every_generated_block_is_the_rendering_of_the_recorded_numbers(twin_rotor_docs, recorded):
    blocks = twin_rotor_docs.read_blocks(DOC.read_text())
    expected = twin_rotor_docs.render(recorded)
    assert set(blocks) == set(expected) == {"rig", "seeds", "seed_rows", "design", "steps", "saturation"}
    for name, text in expected.items():
        assert blocks[name] == text, f"block {name!r} differs: run benchmarks/twin_rotor_docs.py"


def test_recorded_numbers_are_what_the_code_computes(twin_rotor_docs, twin_rotor_study, recorded):
    docs = twin_rotor_docs
    fresh = docs.render({"rig": docs.rig_numbers(twin_rotor_study.rig), "study": docs.study_numbers(twin_rotor_study)})
    stored = docs.render(recorded)
    for name, text in fresh.items():
        assert text == stored[name], f"block {name!r} no longer matches the code: run benchmarks/twin_rotor_docs.py"
    # Settings are compared whole: a changed sequence or weight must show in the doc.
    assert docs.study_numbers(twin_rotor_study)["settings"] == recorded["study"]["settings"]


def test_recorded_seed_study_matches_a_recomputed_seed(twin_rotor_docs, no_coulomb_seed0, recorded):
    docs = twin_rotor_docs
    rig, data, result = no_coulomb_seed0
    row = docs.seeds.seed_row(rig, 0, identified=(data, result))
    stored = recorded["seeds"]["no Coulomb"]
    assert docs.seed_line(row) == docs.seed_line(stored["rows"][0])
    assert docs.pole_text(docs.pair(docs.seeds.linear_pitch_pole(rig)), 4) == docs.pole_text(stored["pitch_pole"], 4)
    assert [r["seed"] for r in stored["rows"]] == list(range(10))

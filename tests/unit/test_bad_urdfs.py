"""The corpus of malformed URDFs (tests/data/bad/): each raises its documented error, quickly."""
import json
import time
from pathlib import Path

import pytest

import manipdyn as md

BAD = Path(__file__).resolve().parent.parent / "data" / "bad"
EXPECTED = json.loads((BAD / "expected.json").read_text())


def test_corpus_is_complete():
    assert len(EXPECTED) >= 25
    assert sorted(EXPECTED) == sorted(p.name for p in BAD.glob("*.urdf"))


@pytest.mark.parametrize("name", sorted(EXPECTED))
def test_bad_urdf_raises_its_error(name):
    exp = EXPECTED[name]
    err = getattr(md, exp["error"])
    t0 = time.perf_counter()
    with pytest.raises(err, match=exp["match"]) as info:
        md.load_urdf(BAD / name)
    assert time.perf_counter() - t0 < 0.5          # entity bombs are refused, not expanded
    assert name in str(info.value)                 # the message names the file

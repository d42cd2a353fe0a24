"""The numpy all-MiniLM-L6-v2: the properties a sentence embedding must have. sentence-transformers and torch are
not installed here, so its vectors are not compared with the reference implementation's; these tests check what
can be checked without it (meaning, padding, truncation, determinism)."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from agentic_core.contracts.extras import MissingExtra
from agentic_core.memory import SqliteStore
from agentic_core.memory.embed import minilm as minilm_module
from agentic_core.memory.embed import resolve

PARAPHRASES = [
    ("A man is eating food.", "A man is eating a piece of bread.", "A woman is playing the violin."),
    (
        "The pilgrim collapsed from the heat.",
        "A person fainted because it was too hot.",
        "The drone's battery is full.",
    ),
    ("The crowd is too dense near the bridge.", "Too many people are packed by the bridge.", "Rain is expected later."),
    ("Send an ambulance to the east gate.", "An ambulance is needed at the eastern entrance.", "I like green tea."),
]


@pytest.mark.parametrize(("anchor", "paraphrase", "unrelated"), PARAPHRASES)
def test_a_paraphrase_is_closer_than_an_unrelated_sentence(
    minilm: Any, anchor: str, paraphrase: str, unrelated: str
) -> None:
    a, p, u = minilm.embed([anchor, paraphrase, unrelated])
    assert float(a @ p) > float(a @ u) + 0.25


def test_vectors_are_unit_384_wide_and_deterministic(minilm: Any) -> None:
    first = minilm.embed(["heat stroke triage", ""])
    again = minilm.embed(["heat stroke triage", ""])
    assert first.shape == (2, 384) and first.dtype == np.float32
    assert np.allclose(np.linalg.norm(first, axis=1), 1.0, atol=1e-5)
    assert np.array_equal(first, again)


def test_padding_in_a_batch_does_not_change_a_sentence(minilm: Any) -> None:
    """A short sentence batched with a long one is padded; the mask must keep the padding out of its vector."""
    short = "casualty at the ramp"
    alone = minilm.embed([short])[0]
    batched = minilm.embed([short, "a much longer sentence " * 8])[0]
    assert float(alone @ batched) > 0.99999


def test_a_text_longer_than_the_model_reads_is_cut_not_refused(minilm: Any) -> None:
    long = "the crowd moves slowly toward the bridge " * 40  # over 256 word pieces
    cut = minilm.embed([long])[0]
    assert cut.shape == (384,) and np.isfinite(cut).all()
    assert float(cut @ minilm.embed([long + " and then something else entirely"])[0]) > 0.9999


def test_search_by_meaning_finds_the_note_with_no_shared_words(minilm: Any) -> None:
    store = SqliteStore(index={"dims": 384, "embed": "all-MiniLM-L6-v2", "fields": ["text"]})
    store.put(("k",), "heat", {"text": "Heat stroke: cool the patient with water and shade before transport."})
    store.put(("k",), "crush", {"text": "Crowd crush: open exits and slow the flow when density exceeds five per m²."})
    store.put(("k",), "battery", {"text": "Swap the battery below twenty percent."})
    assert store.embedding == "all-MiniLM-L6-v2 + BM25"
    assert store.search(("k",), query="a pilgrim fainted in the sun", limit=1)[0].key == "heat"
    assert store.search(("k",), query="too many people squeezed together", limit=1)[0].key == "crush"


def test_without_the_extra_the_model_name_says_what_to_install(monkeypatch: pytest.MonkeyPatch) -> None:
    def missing(module: str, extra: str) -> Any:
        raise MissingExtra(
            f"memory search needs {module}: pip install 'agentic-uavs[{extra}]'", extra=extra, module=module
        )

    monkeypatch.setattr(minilm_module, "require", missing)
    monkeypatch.setattr(minilm_module.MiniLM, "_shared", None)
    with pytest.raises(MissingExtra, match=r"agentic-uavs\[embed\]"):
        resolve("all-MiniLM-L6-v2")

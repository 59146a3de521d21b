"""The ontology joined with usage: which patterns reach a type, who posts it, what is used."""

from __future__ import annotations

import pytest
from ontology_helpers import ONTOLOGY

from openair_ontology.model import TypeEntry, TypeIndex
from openair_ontology.parse import read_ontology
from openair_ontology.relations import Relations, subtree_patterns
from openair_ontology.usage import Posting, Source, Subscription, Usage


@pytest.fixture(scope="module")
def index() -> TypeIndex:
    return TypeIndex(read_ontology(ONTOLOGY))


def _entry(index: TypeIndex, name: str) -> TypeEntry:
    entry = index.get(name)
    assert entry is not None, name
    return entry


def test_a_type_is_reached_only_by_patterns_that_match_it(index: TypeIndex) -> None:
    sub = Subscription(module="M", pattern="AIR.Retrieve.Success")
    rel = Relations(index, Usage(subscriptions=(sub,)))
    assert rel.subscriptions(_entry(index, "AIR.Retrieve")) == []  # a message type with subtypes
    assert rel.subscriptions(_entry(index, "AIR.Retrieve.Success")) == [sub]
    assert rel.subscriptions(_entry(index, "AIR")) == [sub]  # a group: any type below it


def test_family_members_count_as_the_family(index: TypeIndex) -> None:
    posted = Posting(module="Reader", type="Psyclone.Module.Lost.Reader", source=Source.HISTORY)
    rel = Relations(index, Usage(postings=(posted,)))
    lost = _entry(index, "Psyclone.Module.Lost")
    assert rel.postings(lost) == [posted]
    assert rel.used(lost) and not rel.used(_entry(index, "Psyclone.Module.Connect"))


def test_the_catch_all_does_not_make_a_type_used(index: TypeIndex) -> None:
    everything = Subscription(module="Logger", pattern="*")
    rel = Relations(index, Usage(subscriptions=(everything,)))
    done = _entry(index, "Output.Speech.Done")
    assert rel.subscriptions(done) == [everything]
    assert not rel.used(done)


def test_differences_name_the_deviation(index: TypeIndex) -> None:
    rel = Relations(index, Usage(postings=(Posting(module="M", type="Output.Speech"),)))
    (diff,) = rel.differences("Output.Speech.Say.*")
    assert (diff.type, diff.openair, diff.psyclone, diff.deviation) == (
        "Output.Speech",
        False,
        True,
        "DEV-1",
    )


def test_subtree_patterns_most_specific_first() -> None:
    assert subtree_patterns("A.B.C") == ["A.B.C.*", "A.B.*", "A.*", "*"]

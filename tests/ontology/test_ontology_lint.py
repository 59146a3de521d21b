"""`openair ontology lint`: fixtures with known problems, suggestions, exit codes for CI."""

from __future__ import annotations

import json

import pytest
from click.testing import CliRunner
from ontology_helpers import FIXTURES, HISTORY, ONTOLOGY, PSYSPEC

from openair.cli import main
from openair.server.core.config import load_config
from openair_ontology.lint import Finding, Level, lint, nearest_names, suggest
from openair_ontology.model import TypeIndex
from openair_ontology.parse import read_ontology
from openair_ontology.relations import deviation
from openair_ontology.usage import merge, usage_from_config

PROBLEMS = FIXTURES / "problems.psySpec.xml"


@pytest.fixture(scope="module")
def index() -> TypeIndex:
    return TypeIndex(read_ontology(ONTOLOGY))


@pytest.fixture(scope="module")
def problems(index: TypeIndex) -> list[Finding]:
    return lint(index, merge([usage_from_config(load_config(PROBLEMS))]))


def _one(findings: list[Finding], code: str, subject: str) -> Finding:
    found = [f for f in findings if f.code == code and f.subject == subject]
    assert len(found) == 1, [str(f) for f in findings if f.code == code]
    return found[0]


def test_typo_in_a_trigger_gets_the_corrected_pattern(problems: list[Finding]) -> None:
    finding = _one(problems, "unmatched-pattern", "Input.Perc.UniM.Hear.Voise.*")
    assert finding.level is Level.ERROR
    assert finding.suggestions == ("Input.Perc.UniM.Hear.Voice.*",)
    assert "Listener" in finding.message and "PerceptionWB" in finding.message


def test_posted_type_missing_from_the_ontology(problems: list[Finding]) -> None:
    finding = _one(problems, "undefined-type", "Skundar.Decision.Cmd3dMove")
    assert finding.level is Level.ERROR
    assert finding.suggestions == ("Skundar.Decision.Cmd2dMove",)
    assert "Speaker" in finding.message


def test_stream_type_missing_from_the_ontology(problems: list[Finding]) -> None:
    finding = _one(problems, "undefined-stream-type", "Input.Audio.Perceptoin")
    assert finding.suggestions == ("Input.Audio.Perception",)


def test_deprecated_type_in_use_names_its_replacement(problems: list[Finding]) -> None:
    finding = _one(problems, "deprecated-in-use", "Skundar.Decision.Move2d")
    assert finding.level is Level.WARNING
    assert "Speaker" in finding.message and "Skundar.Decision.Cmd2dMove" in finding.message


def test_pattern_psyclone_matches_differently(problems: list[Finding]) -> None:
    # Output.Speech is posted (a group, so also a kind-mismatch); Psyclone 1.1.7 would wake
    # Sayer's Output.Speech.Say.* with it (DEV-1, the prefix quirk), OpenAIR 1.0 does not.
    finding = _one(problems, "psyclone-differs", "Output.Speech.Say.*")
    assert "Output.Speech (DEV-1)" in finding.message
    assert _one(problems, "kind-mismatch", "Output.Speech").level is Level.WARNING


def test_unused_types_are_notes(problems: list[Finding]) -> None:
    finding = _one(problems, "unused-type", "Output.Speech.Done")
    assert finding.level is Level.INFO
    assert not [f for f in problems if f.code == "unused-type" and f.subject == "Output.Speech.Say"]


def test_findings_come_most_serious_first(problems: list[Finding]) -> None:
    levels = [f.level for f in problems]
    assert levels == sorted(levels, reverse=True)


def test_dangling_replacement_and_unknown_module() -> None:
    index = TypeIndex(read_ontology(FIXTURES / "dangling.ontology.xml"))
    findings = lint(index, usage_from_config(load_config(PSYSPEC)))
    dangling = _one(findings, "dangling-replacement", "Test.Old")
    assert dangling.suggestions == ("Test.New",)
    assert "'Ghost'" in _one(findings, "unknown-module", "Test.Old").message


def test_the_example_system_is_clean_of_errors(index: TypeIndex) -> None:
    usage = merge([usage_from_config(load_config(PSYSPEC))])
    findings = lint(index, usage)
    assert [str(f) for f in findings if f.level >= Level.WARNING] == []


@pytest.mark.parametrize(
    ("pattern", "type_", "expected"),
    [
        ("Test.Ping.*", "Test", "DEV-1"),
        ("*Test.Ping.A", "Test.Ping.AB", "DEV-2"),
        ("Test.*.A", "Test.A", "DEV-3"),
        ("*.A", "X.A.A", "DEV-4"),
    ],
)
def test_deviation_names_appendix_a(pattern: str, type_: str, expected: str) -> None:
    assert deviation(pattern, type_) == expected


def test_nearest_names_rank_the_closest_first(index: TypeIndex) -> None:
    assert nearest_names(index, "Skundar.Decision.Cmd2dMov")[0] == "Skundar.Decision.Cmd2dMove"
    assert suggest(index, "Completely.Unrelated.Thing.*", pattern=True) == ()


# --- the command line -----------------------------------------------------------------------


def _lint(*args: str) -> tuple[int, str]:
    result = CliRunner().invoke(main, ["ontology", "lint", str(ONTOLOGY), *args])
    return result.exit_code, result.output


def test_exit_0_when_clean_at_the_default_level() -> None:
    code, out = _lint("--psyspec", str(PSYSPEC), "--history", str(HISTORY))
    assert code == 0, out
    assert "0 errors, 1 warnings" in out  # the history's JoystickTeleop still posts Move2d


def test_exit_1_at_or_above_fail_on() -> None:
    code, out = _lint("--psyspec", str(PSYSPEC), "--history", str(HISTORY), "--fail-on", "warning")
    assert code == 1
    assert "deprecated-in-use" in out
    assert _lint("--psyspec", str(PROBLEMS))[0] == 1
    assert _lint("--psyspec", str(PROBLEMS), "--fail-on", "never")[0] == 0


def test_json_output_lists_every_finding() -> None:
    code, out = _lint("--psyspec", str(PROBLEMS), "--json")
    assert code == 1
    findings = json.loads(out)
    typo = next(f for f in findings if f["subject"] == "Input.Perc.UniM.Hear.Voise.*")
    assert typo == {
        "level": "error",
        "code": "unmatched-pattern",
        "subject": "Input.Perc.UniM.Hear.Voise.*",
        "message": typo["message"],
        "suggestions": ["Input.Perc.UniM.Hear.Voice.*"],
    }


@pytest.mark.parametrize(
    "args",
    [
        ("--psyspec", "/nonexistent/spec.xml"),
        ("--history", "/nonexistent/history.xml"),
        ("--history", "sqlite:/nonexistent/store.db"),
        ("--psyspec", str(ONTOLOGY)),  # not a psySpec
        ("--history", str(PSYSPEC)),  # not an objectcollection
        ("--fail-on", "sometimes"),
    ],
)
def test_exit_2_for_unreadable_input(args: tuple[str, ...]) -> None:
    code, out = _lint(*args)
    assert code == 2, out


def test_exit_2_for_an_invalid_ontology() -> None:
    result = CliRunner().invoke(main, ["ontology", "lint", str(PSYSPEC)])
    assert result.exit_code == 2
    assert "root must be ontology" in result.output


def test_exit_3_when_the_history_server_is_unreachable(unused_port: int) -> None:
    code, out = _lint("--history", f"127.0.0.1:{unused_port}")
    assert code == 3, out
    assert "cannot connect" in out

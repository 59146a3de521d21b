"""`openair ontology docs`: the static site and the Markdown pages, checked as files.

The browser test (test_ontology_browser.py) checks that the site works; this one checks that it
is self-contained: every relative link and asset exists, nothing points to the network, and the
pages say what the example system does.
"""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any
from urllib.parse import unquote, urlsplit

import pytest
from click.testing import CliRunner
from lxml import html as lxml_html
from ontology_helpers import HISTORY, ONTOLOGY, PSYSPEC

from openair.cli import main
from openair_ontology.diagram import render_svg
from openair_ontology.parse import read_ontology
from openair_ontology.usage import Usage

SENTENCE = "types/Input.Perc.UniM.Hear.Voice.Speak.Sentence"


def _docs(out: Path, *extra: str) -> str:
    args = ["ontology", "docs", str(ONTOLOGY), "--psyspec", str(PSYSPEC)]
    result = CliRunner().invoke(main, [*args, "--history", str(HISTORY), "-o", str(out), *extra])
    assert result.exit_code == 0, result.output
    return result.output


@pytest.fixture(scope="module")
def site(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("site")
    _docs(out)
    return out


def _refs(page: Path) -> list[str]:
    tree = lxml_html.fromstring(page.read_bytes())
    return [
        value
        for el in tree.iter()
        for attr in ("href", "src", "{http://www.w3.org/1999/xlink}href")
        if (value := el.get(attr))
    ]


def test_site_layout(site: Path) -> None:
    names = ["index.html", "diagram.svg", "assets/site.css", "assets/site.js"]
    names += ["assets/search-index.js", f"{SENTENCE}.html", "modules/SpeechRecognizer.html"]
    for name in names:
        assert (site / name).is_file(), name


# Links the ontology itself gives (a namespace's url) are the only ones that may leave the site.
AUTHORED = {ns.url for ns in read_ontology(ONTOLOGY).namespaces if ns.url}


def test_only_the_overview_carries_the_whole_tree(site: Path) -> None:
    # Other pages get an empty tree that site.js builds from the index (one copy, not one per
    # page); the browser test checks that it is built.
    assert 'data-type="Skundar.Decision.Cmd2dMove"' in (site / "index.html").read_text("utf-8")
    page = (site / f"{SENTENCE}.html").read_text("utf-8")
    assert '<ul id="tree" class="tree" role="tree" aria-label="Message types"></ul>' in page
    assert "data-type=" not in page


def test_every_link_is_relative_and_resolves(site: Path) -> None:
    pages = sorted(site.rglob("*.html"))
    assert len(pages) > 60
    for page in pages:
        for ref in _refs(page):
            parts = urlsplit(ref)
            if ref in AUTHORED:
                continue
            assert not parts.scheme and not parts.netloc, (page, ref)  # no network, no file://
            if parts.path:
                target = (page.parent / unquote(parts.path)).resolve()
                assert target.is_file(), (page.relative_to(site), ref)


def test_nothing_is_loaded_from_the_network(site: Path) -> None:
    for path in [*site.rglob("*.html"), *site.rglob("*.svg")]:
        tree = lxml_html.fromstring(path.read_bytes())
        loaded = [el.get("src") for el in tree.iter() if el.get("src")]
        loaded += [el.get("href") for el in tree.iter("link")]
        for ref in loaded:
            assert ref and not urlsplit(ref).scheme and not ref.startswith("//"), (path, ref)
    for path in [*site.rglob("*.js"), *site.rglob("*.css")]:
        text = path.read_text(encoding="utf-8")
        assert "fetch(" not in text and "@import" not in text and "url(" not in text, path
        assert "http:" not in text and "https:" not in text, path


def test_search_index_is_a_script_with_every_type(site: Path) -> None:
    text = (site / "assets/search-index.js").read_text(encoding="utf-8")
    prefix = "window.OPENAIR_INDEX = "
    data = json.loads(text[text.index(prefix) + len(prefix) :].rstrip().rstrip(";"))
    names = {item["n"]: item for item in data}
    assert names["Input.Perc.UniM.Hear.Voice.Speak.Sentence"]["k"] == "message"
    assert names["Input.Audio.Perception"]["k"] == "stream"
    assert names["Skundar.Decision.Move2d"]["x"] is True
    assert names["Psyclone.Context"]["f"] == ":"
    assert (site / names["Skundar.Input.Perc.Track"]["u"]).is_file()


def _element(page: Path, key: str, value: str) -> Any:
    """Return the first element of an HTML page whose attribute `key` holds `value`."""
    root = lxml_html.fromstring(page.read_bytes())
    for el in root.iter():
        if value in (el.get(key) or "").split():
            return el
    raise AssertionError(f"no element with {key}={value!r} in {page}")


def _text(page: Path, element_id: str) -> str:
    return "".join(_element(page, "id", element_id).itertext())


def test_type_page_says_who_posts_and_receives(site: Path) -> None:
    page = site / f"{SENTENCE}.html"
    assert _text(page, "fullname") == "Input.Perc.UniM.Hear.Voice.Speak.Sentence"
    posters = _text(page, "posters")
    assert "SpeechRecognizer" in posters and "psySpec" in posters and "history (1×)" in posters
    receivers = _text(page, "subscribers")
    assert "DialogManager" in receivers and "TurnTaker" in receivers
    patterns = _text(page, "patterns")
    assert "Input.Perc.UniM.*" in patterns and "Input.Perc.UniM.Hear.Voice.Speak.*" in patterns
    examples = _text(page, "examples")
    assert "come here please" in examples and "<message>" in examples  # the wire form too


def test_deprecated_page_links_its_replacement(site: Path) -> None:
    page = site / "types/Skundar.Decision.Move2d.html"
    banner = _element(page, "class", "deprecated-banner")
    links = [a.get("href") for a in banner.iter("a")]
    assert links == ["../types/Skundar.Decision.Cmd2dMove.html"]
    assert "JoystickTeleop" in _text(page, "posters")


def test_family_page_lists_observed_members(site: Path) -> None:
    page = site / "types/Psyclone.Module.Connect.html"
    assert _text(page, "fullname") == "Psyclone.Module.Connect.{module}"
    assert "Psyclone.Module.Connect.Navigator" in _text(page, "observed")


def test_overview_has_the_diagram_inline(site: Path) -> None:
    text = (site / "index.html").read_text(encoding="utf-8")
    svg = text[text.index("<svg") : text.index("</svg>")]
    for name in (
        "PerceptionWB",
        "DecisionWB",
        "MotorWB",
        "Navigator",
        "MotorControl",
        "Skundar.Decision.Cmd2dMove",
        "Input.Perc.UniM.*",
        "Microphone",
    ):
        assert name in svg, name
    assert "Psyclone.Module.Connect.Navigator" not in svg  # family members are left out
    assert 'href="modules/Navigator.html"' in svg


def test_no_diagram_without_a_system() -> None:
    result = render_svg(Usage(), lambda kind, name: "")
    assert result.svg is None and "no psySpec" in result.problem


def test_markdown_output(tmp_path: Path) -> None:
    out = tmp_path / "wiki"
    assert "index.md" in _docs(out, "--format", "md")
    index = (out / "index.md").read_text(encoding="utf-8")
    assert "- [`Input`](types/Input.md)" in index
    assert "![Modules, whiteboards and types](diagram.svg)" in index
    page = (out / f"{SENTENCE}.md").read_text(encoding="utf-8")
    assert page.startswith("[Overview](../index.md) › [Input](../types/Input.md)")
    assert "**Full name:** `Input.Perc.UniM.Hear.Voice.Speak.Sentence`" in page
    assert "| [SpeechRecognizer](../modules/SpeechRecognizer.md) | PerceptionWB | psySpec |" in page
    assert "```xml\n<dictionary>" in page
    deprecated = (out / "types/Skundar.Decision.Move2d.md").read_text(encoding="utf-8")
    assert (
        "Use [`Skundar.Decision.Cmd2dMove`](../types/Skundar.Decision.Cmd2dMove.md)" in deprecated
    )
    for md in out.rglob("*.md"):
        for target in re.findall(r"\]\(([^)#]+)", md.read_text(encoding="utf-8")):
            assert (md.parent / unquote(target)).is_file(), (md, target)


def test_docs_without_psyspec_or_history(tmp_path: Path) -> None:
    result = CliRunner().invoke(main, ["ontology", "docs", str(ONTOLOGY), "-o", str(tmp_path)])
    assert result.exit_code == 0, result.output
    assert "no diagram" in result.output
    assert (tmp_path / f"{SENTENCE}.html").is_file()

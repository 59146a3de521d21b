"""The docs site shows hostile ontology text as text: no markup, no script, no attribute escape."""

from __future__ import annotations

from pathlib import Path
from xml.sax.saxutils import escape

from click.testing import CliRunner
from lxml import html as lxml_html

from openair.cli import main

SCRIPT = "<script>alert('x')</script>"
ATTRIBUTE = '"><img src=x onerror=alert(1)>'
S = escape(SCRIPT)
A = escape(ATTRIBUTE, {'"': "&quot;"})

ONTOLOGY = f"""<?xml version="1.0" encoding="UTF-8"?>
<ontology name="Evil {S}" version="1" format="1.0">
  <description>Overview {S} and Evil.Thing.</description>
  <namespace prefix="Evil" owner="{A}"
             version="1" url="javascript:alert(1)">
    <description>{S}</description>
  </namespace>
  <type segment="Evil">
    <description>Group {S}</description>
    <type segment="Thing">
      <description>Title {A}. More {S}</description>
      <content language="text">{S}</content>
      <example title="{S}" from="M" to="WB" language="text">&lt;/pre&gt;{S}</example>
      <poster module="M" whiteboard="WB"/>
    </type>
  </type>
</ontology>
"""


def test_hostile_text_stays_text(tmp_path: Path) -> None:
    source = tmp_path / "evil.ontology.xml"
    source.write_text(ONTOLOGY, encoding="utf-8")
    out = tmp_path / "site"
    result = CliRunner().invoke(main, ["ontology", "docs", str(source), "-o", str(out)])
    assert result.exit_code == 0, result.output
    pages = [out / "index.html", out / "types" / "Evil.Thing.html", out / "types" / "Evil.html"]
    for page in pages:
        tree = lxml_html.fromstring(page.read_bytes())
        scripts = tree.xpath("//script")
        assert [s.get("src") for s in scripts] == [
            s.get("src") for s in scripts if s.get("src", "").endswith(".js")
        ]
        assert all(not (s.text or "").strip() for s in scripts), page  # no inline script
        assert tree.xpath("//img") == [] and tree.xpath("//@onerror") == [], page
        assert SCRIPT in tree.text_content(), page  # shown, as text
    thing = lxml_html.fromstring((out / "types" / "Evil.Thing.html").read_bytes())
    assert any(SCRIPT in pre.text_content() for pre in thing.xpath("//pre"))
    index = lxml_html.fromstring((out / "index.html").read_bytes())
    assert any(ATTRIBUTE in td.text_content() for td in index.xpath("//td"))
    hrefs = [h.strip().lower() for page in pages for h in lxml_html.parse(page).xpath("//@href")]
    assert not [h for h in hrefs if h.startswith("javascript:")]  # an authored url, not a link

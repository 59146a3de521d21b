"""Reporters: handlers of the engine's event stream that render a run for people and machines.

Each module provides one reporter (README, "Reporters"); the CLI imports them by name:

- `console.ConsoleReporter(stream, verbose)`: live progress, the summary, failure details;
- `junit.JUnitReporter(path)`: JUnit XML (Jenkins/Ant form, `schemas/junit.xsd`);
- `jsonreport.JsonReporter(path)`: the JSON report (`schemas/report.schema.json`);
- `html.HtmlReporter(path)`: one self-contained HTML page, and `html.write_comparison`, which
  renders several JSON reports side by side.

Every reporter takes `handle(event)` for each event and `close()` exactly once, also when no
event came (the target was unreachable): then the file reporters write nothing.
"""

from __future__ import annotations

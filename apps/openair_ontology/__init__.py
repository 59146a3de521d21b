"""Message-type ontologies: the file format, generated docs, inference from history, a linter.

An ontology (schemas/ontology.xsd) writes down the dot-delimited types of one system as a tree.
`parse.read_ontology` reads it, `site.write_site` and `markdown.write_markdown` document it,
`infer.infer_ontology` drafts one from a recorded history, and `lint.lint` checks it against a
psySpec and a history. `cli_ontology` is the `openair ontology` command group.
"""

from __future__ import annotations

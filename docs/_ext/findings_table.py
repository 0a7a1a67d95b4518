"""``.. findings-table::``: the finding kinds as the code declares them (``dynval.FINDING_KINDS``), so
the site's list cannot drift from the rules."""

from __future__ import annotations

from docutils import nodes
from docutils.parsers.rst import Directive


class FindingsTable(Directive):
    has_content = False

    def run(self) -> list[nodes.Node]:
        from dynval import FINDING_KINDS

        table = nodes.table(classes=["findings-table"])
        group = nodes.tgroup(cols=2)
        table += group
        for width in (25, 75):
            group += nodes.colspec(colwidth=width)
        head = nodes.thead()
        group += head
        head += _row("kind", "what it detects")
        body = nodes.tbody()
        group += body
        for kind, description in FINDING_KINDS.items():
            body += _row(kind, description, literal=True)
        return [table]


def _row(first: str, second: str, literal: bool = False) -> nodes.row:
    row = nodes.row()
    cell = nodes.entry()
    cell += nodes.paragraph("", "", nodes.literal(first, first) if literal else nodes.Text(first))
    row += cell
    cell = nodes.entry()
    cell += nodes.paragraph("", second)
    row += cell
    return row


def setup(app):
    app.add_directive("findings-table", FindingsTable)
    return {"parallel_read_safe": True, "parallel_write_safe": True}

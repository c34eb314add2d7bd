"""Small HTML helpers shared by the report's sections."""

import html

__all__ = ["p_value", "table"]


def table(rows, columns, formats=None):
    """An HTML table of ``rows`` (dicts) with ``columns``, values escaped.

    Parameters
    ----------
    rows : list of dict
        One dict per row.
    columns : list of str
        The columns, in order (a row without one gets an empty cell).
    formats : dict of str to str or None, default=None
        Format specs of numeric columns.

    Returns
    -------
    html : str
        The ``<table>`` element.
    """
    formats = formats or {}
    head = "".join(f"<th>{html.escape(c)}</th>" for c in columns)
    body = []
    for row in rows:
        cells = []
        for c in columns:
            value = row.get(c, "")
            fmt = formats.get(c)
            if fmt and isinstance(value, (int, float)) and value is not None:
                value = format(value, fmt)
            cells.append(f"<td>{html.escape(str(value))}</td>")
        body.append("<tr>" + "".join(cells) + "</tr>")
    return f"<table><tr>{head}</tr>{''.join(body)}</table>"


def p_value(value):
    """A p-value (or any figure) to 3 significant digits; ``n/a`` for None."""
    return "n/a" if value is None else f"{value:.3g}"

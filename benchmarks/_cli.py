"""What the benchmark scripts' command lines share.

A script run as ``python benchmarks/NAME.py`` finds this module beside it
(its folder is the first entry of ``sys.path``).
"""

import argparse
import ast

__all__ = ["parse_setting"]


def parse_setting(text):
    """``"PARAM=VALUE"`` as ``(PARAM, value)``, for a ``--set`` option.

    The value is read as a Python literal (a number, a tuple, ``True``,
    ``None``, a quoted string); anything else is kept as the string it is.

    Parameters
    ----------
    text : str
        The option's argument.

    Returns
    -------
    setting : tuple of (str, object)
        The parameter's name and its value.
    """
    name, sep, value = text.partition("=")
    if not sep or not name.isidentifier():
        raise argparse.ArgumentTypeError(f"expected PARAM=VALUE; got {text!r}")
    try:
        return name, ast.literal_eval(value)
    except (ValueError, SyntaxError):  # a bare word is a string
        return name, value

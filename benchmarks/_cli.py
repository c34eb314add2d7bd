"""What the benchmark scripts' command lines share.

A script run as ``python benchmarks/NAME.py`` finds this module beside it
(its folder is the first entry of ``sys.path``).
"""

import argparse
import ast

__all__ = ["parse_setting", "suite_parser"]


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


def suite_parser(description):
    """The command line of a script that fits the missing-physics suite.

    ``--machines`` (default: every machine), ``--seeds`` (0 1 2), ``--n-jobs``
    (1: machines and seeds in parallel where more) and ``--set PARAM=VALUE``
    (repeatable: a hybrid parameter other than its default).

    Parameters
    ----------
    description : str
        The script's description.

    Returns
    -------
    parser : argparse.ArgumentParser
        The parser, for the script to add its own options to.
    """
    from skhybrid.datasets import MISSING_PHYSICS_MACHINES

    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("--machines", nargs="+", default=list(MISSING_PHYSICS_MACHINES))
    parser.add_argument("--seeds", nargs="+", type=int, default=[0, 1, 2])
    parser.add_argument("--n-jobs", type=int, default=1)
    parser.add_argument(
        "--set",
        type=parse_setting,
        action="append",
        default=[],
        metavar="PARAM=VALUE",
        help="a hybrid parameter other than its default (repeatable)",
    )
    return parser

"""Shared docstring fragments: filled where named, at the placeholder's indent."""

import importlib
import inspect

import pytest

from skhybrid.utils._docstrings import (
    NO_NOISE_SIMULATE_OPTIONS,
    fill_doc,
    fill_docstring,
)
from skhybrid.utils.discovery import PUBLIC_MODULES


def test_fill_docstring_indents_each_line_as_the_placeholder():
    doc = "Summary.\n\n    Parameters\n    ----------\n        %(entry)s\n"
    filled = fill_docstring(doc, entry="x : int\n    A number.")
    assert filled.splitlines()[4:6] == ["        x : int", "            A number."]


def test_fill_docstring_refuses_an_unknown_fragment():
    with pytest.raises(KeyError, match=r"%\(missing\)s"):
        fill_docstring("Summary.\n\n    %(missing)s\n", entry="x : int")


def test_fill_doc_fills_a_class_and_its_methods():
    @fill_doc(entry="x : int\n    A number.")
    class Model:
        """A model.

        Parameters
        ----------
        %(entry)s
        """

        def method(self, x):
            """Use x.

            Parameters
            ----------
            %(entry)s
            """

    assert "        x : int\n            A number." in Model.__doc__
    assert "            x : int\n                A number." in Model.method.__doc__


def test_fill_doc_refuses_a_fragment_no_docstring_names():
    with pytest.raises(KeyError, match=r"\['entry'\]"):

        @fill_doc(entry="x : int")
        def f():
            """Nothing to fill."""


def _public_docstrings():
    for sub in PUBLIC_MODULES:
        module = importlib.import_module(f"skhybrid.{sub}")
        for name in module.__all__:
            obj = getattr(module, name)
            yield f"{sub}.{name}", inspect.getdoc(obj)
            if inspect.isclass(obj):
                for attr, member in inspect.getmembers(obj, inspect.isfunction):
                    yield f"{sub}.{name}.{attr}", inspect.getdoc(member)


def test_no_public_docstring_keeps_a_placeholder():
    left = [name for name, doc in _public_docstrings() if doc and "%(" in doc]
    assert not left, f"unfilled placeholders in {left}"


def test_help_shows_the_shared_simulate_options():
    from skhybrid.domain import WienerHammersteinModel
    from skhybrid.hybrid import NARXSimulator, PhysicsCorrection

    for cls in (WienerHammersteinModel, NARXSimulator, PhysicsCorrection):
        doc = cls.simulate.__doc__
        assert NO_NOISE_SIMULATE_OPTIONS.splitlines()[1].strip() in doc
        assert "inputs : array-like of shape (n_times, n_inputs)" in doc

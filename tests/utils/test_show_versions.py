"""skhybrid.show_versions, and the subpackages as lazy attributes (issue 26)."""

import subprocess
import sys
import types

import pytest

import skhybrid
from skhybrid.utils.discovery import PUBLIC_MODULES


def test_show_versions_prints_python_dependencies_and_torch(capsys):
    from skhybrid import show_versions

    assert show_versions is skhybrid.show_versions
    assert show_versions() is None
    out = capsys.readouterr().out
    for heading in ("System:", "Python dependencies:", "torch threads and devices:"):
        assert heading in out
    for name in ("python", "machine", "numpy", "scipy", "scikit-learn", "torch"):
        assert f"{name}: " in out
    assert f"skhybrid: {skhybrid.__version__}" in out
    for key in ("num_threads", "num_interop_threads", "cuda_available"):
        assert f"{key}: " in out
    torch = pytest.importorskip("torch")
    assert f"num_threads: {torch.get_num_threads()}" in out
    assert f"cuda_available: {torch.cuda.is_available()}" in out


def test_show_versions_reports_a_missing_dependency(monkeypatch):
    from skhybrid.utils import _show_versions

    monkeypatch.setattr(
        _show_versions, "_DEPENDENCIES", ("numpy", "no-such-distribution-xyz")
    )
    info = _show_versions._get_deps_info()
    assert info["no-such-distribution-xyz"] is None
    assert info["skhybrid"] == skhybrid.__version__


@pytest.mark.parametrize("name", PUBLIC_MODULES)
def test_every_public_subpackage_is_an_attribute(name):
    top, *rest = name.split(".")
    module = getattr(skhybrid, top)
    for part in rest:  # a public module of a subpackage: skhybrid.neural.engine
        module = getattr(module, part)
    assert isinstance(module, types.ModuleType)
    assert module.__name__ == f"skhybrid.{name}"
    assert top in skhybrid.__all__ and top in dir(skhybrid)


def test_unknown_attribute_raises_attribute_error():
    with pytest.raises(AttributeError, match="no attribute 'simulations'"):
        skhybrid.simulations  # noqa: B018


def test_import_skhybrid_is_light():
    """``import skhybrid`` imports no torch (nor skorch, scikit-learn, matplotlib).

    A fresh interpreter, so that modules other tests imported do not count; this
    keeps ``skhybrid --help`` fast (issue 26).
    """
    heavy = ("torch", "skorch", "sklearn", "matplotlib")
    code = (
        "import sys, skhybrid\n"
        "assert skhybrid.__version__\n"
        f"loaded = [m for m in {heavy!r} if m in sys.modules]\n"
        "print(','.join(loaded))\n"
    )
    result = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True
    )
    assert result.stdout.strip() == "", f"import skhybrid imported {result.stdout}"

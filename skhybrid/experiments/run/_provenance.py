"""What code and which CPU kernels made a run: recorded in its seal and identity.

A sealed selection vouches for the figures only together with the code that made
them and the kernels it ran on (networks trained with other CPU kernels round
otherwise and end elsewhere). :func:`provenance` names them: the installed
skhybrid version, the commit of the repository it was imported from (or the
version control hash pip recorded at install), whether that tree held changes,
and the kernels of torch and of the BLAS library.
"""

import functools
import json
import subprocess
from importlib.metadata import PackageNotFoundError, distribution
from pathlib import Path

import skhybrid

__all__ = ["provenance"]


def _git(*args):
    root = Path(skhybrid.__file__).resolve().parents[1]
    if not (root / ".git").exists():
        return None
    try:
        out = subprocess.run(
            ["git", "-C", str(root), *args],
            capture_output=True,
            text=True,
            timeout=10,
            check=True,
        )
    except (OSError, subprocess.SubprocessError):
        return None
    return out.stdout.strip()


def _installed_vcs():
    """The commit pip recorded when skhybrid was installed from a repository."""
    try:
        text = distribution("skhybrid").read_text("direct_url.json")
    except PackageNotFoundError:
        return None
    if not text:
        return None
    info = json.loads(text).get("vcs_info") or {}
    return info.get("commit_id")


def _kernels():
    """torch's CPU capability and the BLAS libraries' core types."""
    out = {}
    try:
        import torch

        out["torch"] = torch.backends.cpu.get_cpu_capability()
    except (ImportError, AttributeError):
        out["torch"] = None
    try:
        from threadpoolctl import threadpool_info

        out["blas"] = sorted(
            {
                f"{info.get('internal_api')}:{info.get('architecture')}"
                for info in threadpool_info()
                if info.get("user_api") == "blas"
            }
        )
    except ImportError:
        out["blas"] = None
    return out


@functools.cache
def provenance():
    """The code and kernels of this process, as JSON-ready data.

    Returns
    -------
    provenance : dict
        ``skhybrid`` (the version), ``commit`` (the repository's ``HEAD``, or
        the commit recorded at install, or None), ``modified`` (whether the
        repository held uncommitted changes to tracked files; None where
        unknown) and ``kernels`` (torch's CPU capability and the BLAS
        libraries' ``api:architecture``).
    """
    commit = _git("rev-parse", "HEAD")
    modified = None
    if commit is not None:
        status = _git("status", "--porcelain", "--untracked-files=no")
        modified = None if status is None else bool(status)
    else:
        commit = _installed_vcs()
    return {
        "skhybrid": skhybrid.__version__,
        "commit": commit,
        "modified": modified,
        "kernels": _kernels(),
    }

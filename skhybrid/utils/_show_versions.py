"""Print the versions a bug report needs, as :func:`sklearn.show_versions` does."""

import platform
import sys
from importlib.metadata import PackageNotFoundError, version

__all__ = ["show_versions"]

#: Distributions reported, skhybrid's dependencies first (pyproject.toml).
_DEPENDENCIES = (
    "numpy",
    "scipy",
    "scikit-learn",
    "torch",
    "skorch",
    "statsmodels",
    "joblib",
    "matplotlib",
    "pandas",
    "threadpoolctl",
    "pip",
    "setuptools",
)


def _get_sys_info():
    """Python, its executable and the platform, as a dict of str."""
    return {
        "python": sys.version.replace("\n", " "),
        "executable": sys.executable,
        "machine": platform.platform(),
    }


def _get_deps_info():
    """Versions from package metadata (nothing imported); None where absent."""
    import skhybrid

    info = {"skhybrid": skhybrid.__version__}
    for name in _DEPENDENCIES:
        try:
            info[name] = version(name)
        except PackageNotFoundError:
            info[name] = None
    return info


def _get_torch_info():
    """torch's threads and devices; imports torch, so only when asked."""
    try:
        import torch
    except ImportError:
        return {"torch": "not installed"}
    cuda = torch.cuda.is_available()
    info = {
        "num_threads": torch.get_num_threads(),
        "num_interop_threads": torch.get_num_interop_threads(),
        "cuda_available": cuda,
        "cuda_version": torch.version.cuda,
        "cuda_devices": (
            ", ".join(
                torch.cuda.get_device_name(i) for i in range(torch.cuda.device_count())
            )
            if cuda
            else None
        ),
    }
    mps = getattr(torch.backends, "mps", None)
    info["mps_available"] = bool(mps is not None and mps.is_available())
    return info


def show_versions():
    """Print the versions of Python, skhybrid, its dependencies and torch's devices.

    The information to paste into a bug report, laid out as
    :func:`sklearn.show_versions` lays out its own: the system, the installed
    versions of skhybrid's dependencies (read from package metadata; ``None``
    for one that is not installed), then torch's thread counts and whether CUDA
    (and Apple's MPS) is available. Importing skhybrid does not import torch;
    this function does, to ask it about threads and devices.

    See Also
    --------
    sklearn.show_versions : The same report for scikit-learn.

    Examples
    --------
    >>> import skhybrid
    >>> skhybrid.show_versions()  # doctest: +SKIP
    <BLANKLINE>
    System:
        python: 3.12.3 ...
    ...
    """
    sections = (
        ("System", _get_sys_info(), 10),
        ("Python dependencies", _get_deps_info(), 13),
        ("torch threads and devices", _get_torch_info(), 19),
    )
    for title, info, width in sections:
        print(f"\n{title}:")
        for key, value in info.items():
            print(f"{key:>{width}}: {value}")

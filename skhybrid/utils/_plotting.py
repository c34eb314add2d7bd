"""Plotting helpers shared by the Displays of every subpackage."""

import numpy as np

__all__ = ["import_pyplot", "output_names", "panels"]


def import_pyplot(caller):
    """matplotlib.pyplot, or an ImportError naming ``caller`` and the fix."""
    try:
        import matplotlib.pyplot as plt
    except ImportError as exc:  # pragma: no cover - matplotlib is installed in CI
        raise ImportError(
            f"{caller} needs matplotlib; install it with `pip install matplotlib` "
            "or `pip install skhybrid[plot]`."
        ) from exc
    return plt


def panels(ax, n_rows, n_cols, caller, *, panel_size=(4.0, 3.0), sharex=False):
    """An (n_rows, n_cols) array of Axes: new ones for ``ax=None``, else ``ax``."""
    plt = import_pyplot(caller)
    if ax is None:
        fig, axes = plt.subplots(
            n_rows,
            n_cols,
            squeeze=False,
            sharex=sharex,
            figsize=(panel_size[0] * n_cols, panel_size[1] * n_rows),
            layout="constrained",
        )
        return fig, axes
    axes = np.asarray(ax, dtype=object).ravel()
    if axes.size != n_rows * n_cols:
        raise ValueError(
            f"ax must hold one Axes per panel ({n_rows} x {n_cols} = "
            f"{n_rows * n_cols}); got {axes.size} Axes."
        )
    return axes[0].figure, axes.reshape(n_rows, n_cols)


def output_names(names, n_outputs):
    """Names of ``n_outputs`` outputs: ``names`` checked, or y, y0, y1, ..."""
    if names is None:
        return [f"y{j}" for j in range(n_outputs)] if n_outputs > 1 else ["y"]
    names = [str(name) for name in names]
    if len(names) != n_outputs:
        raise ValueError(
            f"output_names must name each of the {n_outputs} outputs; got "
            f"output_names={names!r}."
        )
    return names

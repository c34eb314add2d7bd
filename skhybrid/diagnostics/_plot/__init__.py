"""The paper's figures as scikit-learn style Display objects, one module each.

- :mod:`~skhybrid.diagnostics._plot.residual_acf`: :class:`ResidualACFDisplay`,
  residual autocorrelation per output with its confidence band and the
  Ljung-Box p-value (the paper's Fig. 5 and 8);
- :mod:`~skhybrid.diagnostics._plot.rmse_box`: :class:`RMSEBoxDisplay`, box plots
  of RMSE in dB over short windows, one box per model (Fig. 3, 4, 6, 7 and 9);
- :mod:`~skhybrid.diagnostics._plot.decomposition`: :class:`DecompositionDisplay`,
  a trajectory split into its domain part, neural parts and noise band.

matplotlib is imported inside ``plot`` only, so it stays an optional dependency.
"""

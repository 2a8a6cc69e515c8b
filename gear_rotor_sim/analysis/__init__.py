"""Analyses of simulated (or measured) responses and the paper's figures.

Modules
-------
signals
    Amplitude, order and envelope spectra, synchronous average, RMS (shared with calibration).
poincare
    Once-per-mesh-period Poincare samples and phase-portrait data.
classify
    Motion classification (period-n / quasi-periodic / chaotic) and the 0-1 test for chaos.
bifurcation
    Bifurcation sweep over speed with continuation, parallel (local processes or Dask), npz cache.
sweep
    Speed x temperature x backlash x bearing-type sweeps of bearing forces, displacements, orbits.
figures
    Matplotlib (Agg) PNG figures of the paper's Figs 6-10 and of single-speed analyses.
reproduce
    The ``gear-rotor-sim reproduce`` command writing ``docs/REPRODUCTION.md``.

The analyses consume sample arrays or the simulator's steady-state runner; they never integrate.
Submodules are imported on use so that ``import gear_rotor_sim.analysis`` stays light.
"""

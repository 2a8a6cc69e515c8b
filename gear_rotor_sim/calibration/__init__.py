"""Calibration: measured data in, the missing physical effect out (issue 6, docs/calibration.md).

``measurement`` (data contract and loaders), ``residual`` (model runs, alignment, features,
metrics), ``fit`` (ranking, parsimony, stopping rule), ``report`` (Markdown/PNG/JSON), ``cwru``
(the CWRU bearing rig), ``calibrate_cli`` (``gear-rotor-sim calibrate``). The effect library is
``gear_rotor_sim.faults``.
"""

from gear_rotor_sim.calibration.measurement import Measurement, MeasurementError, load_measurement

__all__ = ["Measurement", "MeasurementError", "load_measurement"]

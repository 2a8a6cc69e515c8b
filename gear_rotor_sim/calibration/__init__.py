"""Calibration: measured data in, the missing physical effect out (issue 6, docs/calibration.md).

``measurement`` (data contract and loaders; ``measurement_contract``, ``measurement_checks``,
``measurement_files``), ``residual`` (alignment, features, metrics; ``model_runner`` the model runs,
``signal_features``, ``residual_envelope``, ``residual_types``), ``fit`` (ranking, parsimony, stopping
rule; ``fit_types`` and the ``Calibrator``'s mixins ``fit_model``, ``fit_screens``, ``fit_candidates``,
``fit_verify``, ``fit_refine``), ``report`` (Markdown/PNG/JSON), ``cwru`` (the CWRU bearing rig),
``calibrate_cli`` (``gear-rotor-sim calibrate``). The effect library is ``gear_rotor_sim.faults``.
"""

from gear_rotor_sim.calibration.measurement import Measurement, MeasurementError, load_measurement

__all__ = ["Measurement", "MeasurementError", "load_measurement"]

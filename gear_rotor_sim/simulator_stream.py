"""The Simulator's stream output: ``advance`` / ``advance_deferred``, the pending blocks and their
decimation into :class:`~gear_rotor_sim.blocks.SampleBlock`.

Part of :class:`gear_rotor_sim.simulator.Simulator` (docs/solver.md, "Module layout", "dt rule and
decimation"): :class:`Stream` is one of its bases and holds no state of its own.
"""

from __future__ import annotations

import time
from typing import TYPE_CHECKING

import numpy as np

from gear_rotor_sim.blocks import SampleBlock

if TYPE_CHECKING:
    from gear_rotor_sim.simulator import Simulator


class PendingBlock:
    """A block integrated by :meth:`Simulator.advance_deferred` whose samples are not filtered yet.

    ``first_index``, ``n_samples`` and ``t0`` are known at once; :meth:`result` runs the decimation
    (once; later calls return the same block).
    """

    __slots__ = ("_block", "_sim", "first_index", "n_samples", "t0")

    def __init__(self, sim: Simulator, first_index: int, n_samples: int) -> None:
        self._sim: Simulator | None = sim
        self.first_index = first_index
        self.n_samples = n_samples
        self.t0 = first_index / sim.output_rate_hz
        self._block: SampleBlock | None = None

    def result(self) -> SampleBlock:
        """The :class:`SampleBlock` (what :meth:`Simulator.advance` returns)."""
        if self._block is None:
            assert self._sim is not None
            self._block = self._sim._output_block(self.first_index, self.n_samples)
            self._sim = None
        return self._block


class Stream:
    """Output blocks of a :class:`~gear_rotor_sim.simulator.Simulator`: integrate (``Stepping``) and
    emit the decimated samples."""

    def advance(self, duration: float) -> SampleBlock:
        """Integrate and return the output samples with times in [time_s, time_s + duration)."""
        return self.advance_deferred(duration).result()

    def advance_deferred(self, duration: float) -> PendingBlock:
        """:meth:`advance` with the output filtering left to whoever calls ``result()``.

        Integrates now (the simulator is at ``time_s + duration`` on return) and returns a
        :class:`PendingBlock` that knows the block's first sample index and length; its ``result()``
        runs the anti-aliasing decimation of the raw samples and returns the :class:`SampleBlock`
        that :meth:`advance` would have returned, bit for bit. Pending blocks must be resolved in the
        order they were made (a ValueError otherwise); ``result()`` may run in another thread,
        concurrently with the next ``advance_deferred`` (the simulator node does so: the FIR then runs
        on the other core while the next chunk is integrated). ``last_chunk_stats["wall_s"]`` counts
        the integration only.
        """
        if not (np.isfinite(duration) and duration >= 0):
            raise ValueError(f"duration: {duration!r} must be finite and >= 0")
        wall0 = time.perf_counter()
        n_target = int(np.ceil((self.time_s + duration) * self.output_rate_hz - 1e-9))
        n_emit = n_target - self._n_out
        got = 0
        steps = n_loss = n_back = 0
        try:
            while got < n_emit:
                need_raw = (n_target - 1) * 1.0 / self.output_rate_hz  # last output time
                dt = self.dt
                t_raw = self._raw_time
                n_steps = int(np.ceil((need_raw - t_raw) / dt - 1e-9)) + self._dec.delay
                n_steps = max(n_steps, 1)
                n_steps = self._limit_chunk(n_steps, t_raw, dt)
                n_y, loss, back = self._run_steps(n_steps)
                steps += n_steps
                n_loss += loss
                n_back += back
                if n_y:
                    take = min(n_y, n_emit - got)
                    got += take
                    self._pending_n = n_y - take
                self._maybe_regrid()
        except BaseException:
            self._pending_n += got  # completed outputs stay queued for the next block, in order
            raise
        first = self._n_out
        self._n_out += got
        self.last_chunk_stats = {
            "contact_loss_fraction": n_loss / max(steps, 1),
            "back_contact_fraction": n_back / max(steps, 1),
            "steps": float(steps),
            "wall_s": time.perf_counter() - wall0,
            "dt_s": self.dt,
            "decimation": float(self._k),
            "located": float(self.locate_events),
            "exact_modal_map": float(self._exact),
            "contact_loss_rule": float(self._loss_mode),
            "mesh_solve_failures": float(self._stepper.n_mesh_fail),
        }
        return PendingBlock(self, first, got)

    def _output_block(self, first: int, n: int) -> SampleBlock:
        """The decimated samples ``first .. first + n - 1`` as a block (see :class:`PendingBlock`)."""
        data = self._dec.take(n, first)
        nch = len(self.channels)
        return SampleBlock(
            first / self.output_rate_hz,
            self.output_rate_hz,
            self.channels,
            self.units,
            np.ascontiguousarray(data[:, :nch]),
            first,
            data[:, nch].copy(),
            data[:, nch + 1].copy(),
        )

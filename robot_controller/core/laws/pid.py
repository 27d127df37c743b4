"""PID joint controller with anti-windup, derivative options and limits.

All quantities are arrays with one entry per joint (shape ``(n,)``) and
broadcast, so a batch of gain sets (shape ``(batch, n)``) runs through the
same code. Units: positions rad, velocities rad/s, torques N·m, time s.

The integral is stored as the I term itself (N·m), not as the integral of
the error, so that changing ``ki`` while running does not kick the output
(bumpless gain change).
"""

from __future__ import annotations

import math

import numpy as np

from robot_controller.core.arrays import all_finite, as_shape, clip, is_one_value, sign_scalar, within
from robot_controller.core.laws.pid_config import AntiWindup, DerivativeSource, PidConfig, PidTerms

__all__ = ["AntiWindup", "DerivativeSource", "Pid", "PidConfig", "PidTerms"]


class Pid:
    """A discrete PID law, called once per control period with explicit ``dt``.

    ``u = ff + kp·e + I + kd·D``, saturated to ``±output_limit`` and, if set,
    slew-rate limited. ``e = r − y``. Non-finite inputs give a zero command
    and leave the state untouched: the arm never gets a non-finite torque.

    It also runs the LQR: state feedback on ``[∫e, e, ė]`` is a PID whose
    gains come from a Riccati design instead of by hand (``core.law``), so both
    laws share this one implementation of anti-windup, limits and filtering.
    """

    def __init__(self, config: PidConfig) -> None:
        self.config = config
        self._one_joint = _one_joint(config)
        self.reset()

    def reset(self) -> None:
        """Forget the integral, filter and derivative history."""
        self._i_term = np.zeros_like(self.config.kp, dtype=float)
        self._d_filtered: np.ndarray | None = None
        self._prev_error: np.ndarray | None = None
        self._prev_position: np.ndarray | None = None
        self._prev_command: np.ndarray | None = None

    def set_config(self, config: PidConfig) -> None:
        """Swap gains and options while running, without a bump in the output.

        The I term is kept in N·m, so a new ``ki`` changes only how fast it
        grows from here on.
        """
        self.config = config
        self._one_joint = _one_joint(config)
        self._i_term = np.broadcast_to(self._i_term, np.broadcast_shapes(self._i_term.shape, config.kp.shape)).copy()

    @property
    def integral_term(self) -> np.ndarray:
        """The current I term, N·m."""
        return self._i_term.copy()

    def step(
        self,
        dt: float,
        reference_position: np.ndarray,
        reference_velocity: np.ndarray,
        measured_position: np.ndarray,
        measured_velocity: np.ndarray,
        feedforward: np.ndarray | float = 0.0,
        feedback_map: np.ndarray | None = None,
    ) -> PidTerms:
        """Advance one control period of ``dt`` seconds and return the command and its terms.

        ``feedback_map`` (n × n): the feedback torques (P + I + D, each joint's
        own) pass through it before the feedforward is added and the command
        limited; the terms reported are the joints' own."""
        if (
            self._one_joint
            and feedback_map is None
            and is_one_value(reference_position)
            and is_one_value(reference_velocity)
            and is_one_value(measured_position)
            and is_one_value(measured_velocity)
            and (is_one_value(feedforward) or isinstance(feedforward, (float, int)))
            and self._i_term.shape == (1,)
        ):
            return self._step_one_joint(
                float(dt),
                reference_position.item(),
                reference_velocity.item(),
                measured_position.item(),
                measured_velocity.item(),
                feedforward.item() if isinstance(feedforward, np.ndarray) else float(feedforward),
            )
        c = self.config
        zeros = np.zeros(np.broadcast_shapes(np.shape(reference_position), c.kp.shape))
        inputs = (reference_position, reference_velocity, measured_position, measured_velocity, feedforward)
        if not (np.isfinite(dt) and dt > 0) or not all_finite(*inputs):
            return PidTerms(zeros, zeros, zeros, zeros, zeros, np.zeros(zeros.shape, dtype=bool))

        error = reference_position - measured_position
        p_term = c.kp * error

        if c.derivative_source is DerivativeSource.MEASURED_VELOCITY:
            d_signal = -measured_velocity
        elif c.derivative_source is DerivativeSource.VELOCITY_ERROR:
            d_signal = reference_velocity - measured_velocity
        elif c.derivative_source is DerivativeSource.ERROR:
            d_signal = zeros if self._prev_error is None else (error - self._prev_error) / dt
        else:  # MEASUREMENT
            d_signal = zeros if self._prev_position is None else -(measured_position - self._prev_position) / dt
        self._prev_error = np.array(error, dtype=float)
        self._prev_position = np.array(measured_position, dtype=float)
        if c.derivative_filter_time_s > 0:
            if self._d_filtered is None:
                self._d_filtered = np.array(d_signal, dtype=float)
            else:
                alpha = dt / (c.derivative_filter_time_s + dt)
                self._d_filtered = self._d_filtered + alpha * (d_signal - self._d_filtered)
            d_signal = self._d_filtered
        d_term = c.kd * d_signal
        feedforward = as_shape(feedforward, zeros.shape)

        # Integrate, then limit per the anti-windup mode.
        i_candidate = self._i_term + c.ki * error * dt
        if c.anti_windup is AntiWindup.CLAMP:
            i_limit = c.ki * c.integral_limit
            i_candidate = within(i_candidate, i_limit)
        unsaturated = feedforward + _mapped(feedback_map, p_term + i_candidate + d_term)
        limited = self._limit(unsaturated, dt)
        saturated = np.abs(limited - unsaturated) > 1e-12
        if c.anti_windup is AntiWindup.BACK_CALCULATION:
            i_candidate = i_candidate + (limited - unsaturated) * dt / c.back_calculation_time_s
        elif c.anti_windup is AntiWindup.CONDITIONAL_INTEGRATION and saturated.any():
            # Keep integrating only where it would pull the output back inside the limit.
            pushing_out = saturated & (np.sign(error) == np.sign(unsaturated))
            i_candidate = np.where(pushing_out, self._i_term, i_candidate)
        self._i_term = np.asarray(i_candidate, dtype=float)

        command = self._limit(feedforward + _mapped(feedback_map, p_term + self._i_term + d_term), dt)
        command = np.where(np.isfinite(command), command, 0.0)
        self._prev_command = command
        return PidTerms(command, p_term, self._i_term.copy(), d_term, feedforward, saturated)

    def _step_one_joint(
        self,
        dt: float,
        reference_position: float,
        reference_velocity: float,
        measured_position: float,
        measured_velocity: float,
        feedforward: float,
    ) -> PidTerms:
        """:meth:`step` for one joint on Python floats, the same arithmetic in the same
        order: on arrays of one value NumPy's per-call cost is most of the work. The
        state stays in arrays, as :meth:`step` keeps it."""
        c = self.config
        inputs = (dt, reference_position, reference_velocity, measured_position, measured_velocity, feedforward)
        if not (dt > 0 and all(map(math.isfinite, inputs))):
            zero = np.zeros(1)
            return PidTerms(zero, zero, zero, zero, zero, np.zeros(1, dtype=bool))
        kp, ki, kd = c.kp.item(), c.ki.item(), c.kd.item()
        error = reference_position - measured_position
        p_term = kp * error
        source = c.derivative_source
        if source is DerivativeSource.MEASURED_VELOCITY:
            d_signal = -measured_velocity
        elif source is DerivativeSource.VELOCITY_ERROR:
            d_signal = reference_velocity - measured_velocity
        elif source is DerivativeSource.ERROR:
            d_signal = 0.0 if self._prev_error is None else (error - self._prev_error.item()) / dt
        else:  # MEASUREMENT
            d_signal = 0.0 if self._prev_position is None else -(measured_position - self._prev_position.item()) / dt
        self._prev_error = np.array([error])
        self._prev_position = np.array([measured_position])
        if c.derivative_filter_time_s > 0:
            if self._d_filtered is None:
                self._d_filtered = np.array([d_signal])
            else:
                alpha = dt / (c.derivative_filter_time_s + dt)
                filtered = self._d_filtered.item()
                self._d_filtered = np.array([filtered + alpha * (d_signal - filtered)])
            d_signal = self._d_filtered.item()
        d_term = kd * d_signal

        i_term = self._i_term.item()
        i_candidate = i_term + ki * error * dt
        if c.anti_windup is AntiWindup.CLAMP:
            i_limit = ki * c.integral_limit.item()
            i_candidate = min(max(i_candidate, -i_limit), i_limit)
        unsaturated = feedforward + (p_term + i_candidate + d_term)
        limited = self._limit_one_joint(unsaturated, dt)
        saturated = abs(limited - unsaturated) > 1e-12
        if c.anti_windup is AntiWindup.BACK_CALCULATION:
            i_candidate = i_candidate + (limited - unsaturated) * dt / c.back_calculation_time_s
        elif (
            c.anti_windup is AntiWindup.CONDITIONAL_INTEGRATION
            and saturated
            and sign_scalar(error) == sign_scalar(unsaturated)
        ):
            i_candidate = i_term  # integrate only where it would pull the output back inside the limit
        self._i_term = np.array([i_candidate])

        command = self._limit_one_joint(feedforward + (p_term + i_candidate + d_term), dt)
        if not math.isfinite(command):
            command = 0.0
        terms = np.array([command, p_term, i_candidate, d_term, feedforward])
        self._prev_command = terms[0:1]
        return PidTerms(terms[0:1], terms[1:2], terms[2:3], terms[3:4], terms[4:5], np.array([saturated]))

    def _limit_one_joint(self, command: float, dt: float) -> float:
        """:meth:`_limit` on a float."""
        limit = self.config.output_limit.item()
        out = min(max(command, -limit), limit)
        if self.config.slew_rate_limit > 0 and self._prev_command is not None:
            max_step = self.config.slew_rate_limit * dt
            previous = self._prev_command.item()
            out = min(max(out, previous - max_step), previous + max_step)
        return out

    def _limit(self, command: np.ndarray, dt: float) -> np.ndarray:
        limit = self.config.output_limit
        out = within(command, limit)
        if self.config.slew_rate_limit > 0 and self._prev_command is not None:
            max_step = self.config.slew_rate_limit * dt
            out = clip(out, self._prev_command - max_step, self._prev_command + max_step)
        return out


def _mapped(feedback_map: np.ndarray | None, feedback: np.ndarray) -> np.ndarray:
    """The feedback torques through ``feedback_map`` (as they are without one)."""
    return feedback if feedback_map is None else feedback_map @ feedback


def _one_joint(config: PidConfig) -> bool:
    """Whether ``config`` is one joint's (every per-joint value a single one)."""
    return all(getattr(config, name).shape == (1,) for name in ("kp", "ki", "kd", "output_limit", "integral_limit"))

"""Controllers designed on identified models: LQ servo with observer, PID baseline."""

from .closed_loop import (
    ClosedLoopRun, Controller, StepMetrics, closed_loop, setpoint_steps, step_metrics, time_saturated,
)
from .limits import integrator_pairing
from .lq import (
    ControlDesignError, ServoController, bryson, continuous_poles, lq_servo, sector_poles, servo_weights,
)
from .pid import DecentralizedPID, PIDGains, pid_baseline, tune_pid

__all__ = [
    "ClosedLoopRun", "Controller", "StepMetrics", "closed_loop", "setpoint_steps", "step_metrics",
    "time_saturated", "integrator_pairing",
    "ControlDesignError", "ServoController", "bryson", "continuous_poles", "lq_servo",
    "sector_poles", "servo_weights", "DecentralizedPID", "PIDGains", "pid_baseline", "tune_pid",
]

#!/usr/bin/env python3
"""Local shipcast consumer in Python: reads Forecast from iceoryx2 shared memory (zero copy)
through a ctypes structure with the exact layout of the Rust payload (docs/contracts.md
section 2.1).

Needs `pip install iceoryx2==0.10.0` and a pipeline on the same machine
(`cargo run --release -- run`). With `--instance NAME` the pipeline's service names start with
`NAME/` and its iceoryx2 files with the prefix `iox2_NAME_`; pass the same `--instance` here.

    python3 examples/iceoryx2_forecast_reader.py [--instance NAME] [--vessel ddg51] [--count N]
"""

import argparse
import ctypes
import math
import re
import signal
import sys

import iceoryx2 as iox2

MAX_STEPS = 128
NUM_DOF = 6
# The limits of shipcast's services (shipcast_wire::payload::limits): whichever process comes
# first creates the service, and one created with iceoryx2's defaults (2 publishers, no
# history) would keep the predictor from starting.
MAX_PUBLISHERS = 4
MAX_SUBSCRIBERS = 16
MAX_NODES = 32
FORECAST_BUFFER = 8
FORECAST_HISTORY = 1
MAX_NOTIFIERS = 4
MAX_LISTENERS = 16
# What a printed forecast must satisfy (shared memory holds whatever another process wrote).
MAX_ABS_MOTION = 1.0e6
MAX_DT_S = 60.0
NAME = re.compile(r"[A-Za-z0-9._-]{1,64}")


class MotionSample(ctypes.Structure):
    """shipcast::MotionSample, 72 bytes."""

    _fields_ = [
        ("seq", ctypes.c_uint64),
        ("stamp_ns", ctypes.c_uint64),
        ("time_s", ctypes.c_double),
        ("dof", ctypes.c_double * NUM_DOF),
    ]

    @staticmethod
    def type_name() -> str:
        return "shipcast::MotionSample"


class Forecast(ctypes.Structure):
    """shipcast::Forecast, 6200 bytes."""

    _fields_ = [
        ("seq", ctypes.c_uint64),
        ("source_seq", ctypes.c_uint64),
        ("source_stamp_ns", ctypes.c_uint64),
        ("issued_stamp_ns", ctypes.c_uint64),
        ("time_s", ctypes.c_double),
        ("dt_s", ctypes.c_double),
        ("steps", ctypes.c_uint32),
        ("model_version", ctypes.c_uint32),
        ("mean", (ctypes.c_float * MAX_STEPS) * NUM_DOF),
        ("sigma", (ctypes.c_float * MAX_STEPS) * NUM_DOF),
    ]

    @staticmethod
    def type_name() -> str:
        return "shipcast::Forecast"


assert ctypes.sizeof(MotionSample) == 72
assert ctypes.sizeof(Forecast) == 6200


def step_at(f: Forecast, lead_s: float, dofs) -> int:
    """The index of the step nearest `lead_s`, after checking the forecast's shape and the
    values of `dofs` there; ValueError says what is wrong."""
    if not 1 <= f.steps <= MAX_STEPS:
        raise ValueError(f"steps {f.steps}")
    if not (0.0 < f.dt_s <= MAX_DT_S) or not math.isfinite(f.time_s):
        raise ValueError(f"dt_s {f.dt_s}, time_s {f.time_s}")
    k = min(max(round(lead_s / f.dt_s), 1), f.steps) - 1
    for d in dofs:
        mean, sigma = f.mean[d][k], f.sigma[d][k]
        if not (abs(mean) <= MAX_ABS_MOTION and 0.0 <= sigma <= MAX_ABS_MOTION):
            raise ValueError(f"DOF {d} step {k + 1}: mean {mean}, sigma {sigma}")
    return k


STOP = []


def stop(_signum, _frame):
    """Ctrl-C or SIGTERM: noted, and the read loop ends at its next turn (the wait it
    interrupts raises iceoryx2's InterruptSignal, which the loop takes as the stop)."""
    STOP.append(True)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--instance", default="")
    parser.add_argument("--vessel", default="ddg51")
    parser.add_argument("--count", type=int, default=0,
                        help="stop after N forecasts (0: run until Ctrl-C)")
    args = parser.parse_args()
    for flag, value in (("--instance", args.instance), ("--vessel", args.vessel)):
        if (value or flag == "--vessel") and not NAME.fullmatch(value):
            parser.error(f"{flag} '{value}': 1 to 64 characters of A-Z a-z 0-9 . _ -")
    # Ctrl-C and SIGTERM end the loop, so the node and its ports are closed (their files go).
    signal.signal(signal.SIGTERM, stop)
    signal.signal(signal.SIGINT, stop)
    name = f"shipcast/{args.vessel}/forecast"
    config = iox2.config.default()
    if args.instance:
        name = f"{args.instance}/{name}"
        config.global_cfg.prefix = iox2.FileName.new(f"iox2_{args.instance}_")

    iox2.set_log_level_from_env_or(iox2.LogLevel.Warn)
    # Signals are this script's own (KeyboardInterrupt): with iceoryx2's handler, Ctrl-C made
    # timed_wait raise its own error, and the script died with a dump (review).
    node = (iox2.NodeBuilder.new()
            .config(config)
            .signal_handling_mode(iox2.SignalHandlingMode.Disabled)
            .create(iox2.ServiceType.Ipc))
    service = (node.service_builder(iox2.ServiceName.new(name))
               .publish_subscribe(Forecast)
               .max_publishers(MAX_PUBLISHERS)
               .max_subscribers(MAX_SUBSCRIBERS)
               .max_nodes(MAX_NODES)
               .subscriber_max_buffer_size(FORECAST_BUFFER)
               .history_size(FORECAST_HISTORY)
               .enable_safe_overflow(True)
               .open_or_create())
    subscriber = service.subscriber_builder().create()
    # The predictor notifies this event service after every forecast.
    event = (node.service_builder(iox2.ServiceName.new(name + "/event"))
             .event()
             .max_notifiers(MAX_NOTIFIERS)
             .max_listeners(MAX_LISTENERS)
             .max_nodes(MAX_NODES)
             .open_or_create())
    listener = event.listener_builder().create()
    print(f"reading {name} (iceoryx2)", file=sys.stderr)

    received = 0
    while not STOP and (args.count == 0 or received < args.count):
        try:
            listener.timed_wait(iox2.Duration.from_millis(500))
        except iox2.ListenerWaitError as e:
            # A signal interrupts the wait before Python runs its handler.
            if STOP or "InterruptSignal" in str(e):
                break
            raise
        # One wake-up may find several forecasts queued: never more than --count printed.
        while args.count == 0 or received < args.count:
            sample = subscriber.receive()
            if sample is None:
                break
            f = sample.payload().contents
            try:
                k5 = step_at(f, 5.0, (2, 4))
            except ValueError as why:
                print(f"skipped forecast seq {f.seq}: {why}", file=sys.stderr)
                sample.delete()
                continue
            received += 1
            latency_us = max(f.issued_stamp_ns - f.source_stamp_ns, 0) / 1e3
            print(f"seq {f.seq} t={f.time_s:.1f}s v{f.model_version}: "
                  f"in {(k5 + 1) * f.dt_s:.1f} s "
                  f"heave {f.mean[2][k5]:+.2f} m (sigma {f.sigma[2][k5]:.2f}), "
                  f"pitch {math.degrees(f.mean[4][k5]):+.2f} deg, "
                  f"latency {latency_us:.0f} us")
            sample.delete()
    return 0


if __name__ == "__main__":
    sys.exit(main())

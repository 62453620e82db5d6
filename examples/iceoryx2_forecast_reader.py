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
import sys

import iceoryx2 as iox2

MAX_STEPS = 128
NUM_DOF = 6


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


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--instance", default="")
    parser.add_argument("--vessel", default="ddg51")
    parser.add_argument("--count", type=int, default=0,
                        help="stop after N forecasts (0: run until Ctrl-C)")
    args = parser.parse_args()
    name = f"shipcast/{args.vessel}/forecast"
    config = iox2.config.default()
    if args.instance:
        name = f"{args.instance}/{name}"
        config.global_cfg.prefix = iox2.FileName.new(f"iox2_{args.instance}_")

    iox2.set_log_level_from_env_or(iox2.LogLevel.Warn)
    node = iox2.NodeBuilder.new().config(config).create(iox2.ServiceType.Ipc)
    service = (node.service_builder(iox2.ServiceName.new(name))
               .publish_subscribe(Forecast)
               .open_or_create())
    subscriber = service.subscriber_builder().create()
    # The predictor notifies this event service after every forecast.
    event = node.service_builder(iox2.ServiceName.new(name + "/event")).event().open_or_create()
    listener = event.listener_builder().create()
    print(f"reading {name} (iceoryx2)", file=sys.stderr)

    received = 0
    try:
        while args.count == 0 or received < args.count:
            listener.timed_wait(iox2.Duration.from_millis(500))
            while True:
                sample = subscriber.receive()
                if sample is None:
                    break
                f = sample.payload().contents
                received += 1
                k5 = min(f.steps, round(5.0 / f.dt_s)) - 1
                print(f"seq {f.seq} t={f.time_s:.1f}s v{f.model_version}: in 5 s "
                      f"heave {f.mean[2][k5]:+.2f} m (sigma {f.sigma[2][k5]:.2f}), "
                      f"pitch {math.degrees(f.mean[4][k5]):+.2f} deg, "
                      f"latency {(f.issued_stamp_ns - f.source_stamp_ns) / 1e3:.0f} us")
                sample.delete()
    except KeyboardInterrupt:
        pass
    return 0


if __name__ == "__main__":
    sys.exit(main())

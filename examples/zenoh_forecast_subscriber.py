#!/usr/bin/env python3
"""Remote shipcast consumer in Python: subscribes to the forecast JSON over zenoh.

Needs only `pip install eclipse-zenoh` (1.10) and a running predictor
(`cargo run --release -- run`, which listens on tcp/127.0.0.1:17447).

    python3 examples/zenoh_forecast_subscriber.py [--connect tcp/127.0.0.1:17447]
        [--instance NAME] [--vessel ddg51] [--key KEY] [--count N]

Secure setup (docs/security.md): pass the station's configuration written by
`shipcast certs`, which holds the endpoint, TLS and the station's certificate:

    python3 examples/zenoh_forecast_subscriber.py --config DIR/crane.json5 --vessel ddg51
"""

import argparse
import json
import math
import sys

import zenoh

NUM_DOF = 6
MAX_STEPS = 128
MAX_ABS_MOTION = 1.0e6
MAX_DT_S = 60.0
# Where this peer itself listens: loopback, a port of the system's choosing (zenoh's default
# is every interface).
OWN_LISTEN = "tcp/127.0.0.1:0"
# How long to wait for the predictor's liveliness token before saying it is not heard.
ALIVE_PATIENCE_S = 5.0


def forecast_at(payload: bytes, lead_s: float):
    """(forecast, step index nearest lead_s) from the JSON of a forecast; ValueError says why
    a message is not one this script prints (the network carries whatever a peer sent)."""
    try:
        f = json.loads(payload)
        steps, dt = int(f["steps"]), float(f["dt_s"])
        mean, sigma = f["mean"], f["sigma"]
        time_s = float(f["time_s"])
        int(f["seq"]), int(f["model_version"])
    except (ValueError, TypeError, KeyError) as e:
        raise ValueError(f"not a forecast ({type(e).__name__}: {e})") from None
    if not 1 <= steps <= MAX_STEPS or not 0.0 < dt <= MAX_DT_S:
        raise ValueError(f"steps {steps}, dt_s {dt}")
    if not math.isfinite(time_s):  # json.loads takes NaN and Infinity
        raise ValueError(f"time_s {time_s}")
    try:
        shaped = (len(mean) == NUM_DOF and len(sigma) == NUM_DOF
                  and all(len(row) == steps for row in list(mean) + list(sigma)))
    except TypeError:
        shaped = False
    if not shaped:
        raise ValueError("mean and sigma are not 6 arrays of `steps` values")
    k = min(max(round(lead_s / dt), 1), steps) - 1
    for d in (2, 3):
        m, s = mean[d][k], sigma[d][k]
        if not (isinstance(m, (int, float)) and isinstance(s, (int, float))
                and abs(m) <= MAX_ABS_MOTION and 0.0 <= s <= MAX_ABS_MOTION):
            raise ValueError(f"DOF {d} step {k + 1}: mean {m}, sigma {s}")
    return f, k


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--connect", default="tcp/127.0.0.1:17447",
                        help="zenoh endpoint of the predictor")
    parser.add_argument("--instance", default="",
                        help="instance name of the pipeline (prefixes the key with NAME/)")
    parser.add_argument("--vessel", default="ddg51")
    parser.add_argument("--key", default="",
                        help="forecast key; default [<instance>/]shipcast/<vessel>/forecast")
    parser.add_argument("--config", default="",
                        help="zenoh client configuration (JSON5) from `shipcast certs`; "
                             "replaces --connect")
    parser.add_argument("--count", type=int, default=0,
                        help="stop after N forecasts (0: run until Ctrl-C)")
    args = parser.parse_args()
    if not args.key:
        args.key = f"shipcast/{args.vessel}/forecast"
        if args.instance:
            args.key = f"{args.instance}/{args.key}"

    try:
        if args.config:
            config = zenoh.Config.from_file(args.config)
            args.connect = args.config
        else:
            config = zenoh.Config()
            config.insert_json5("mode", '"peer"')
            config.insert_json5("connect/endpoints", json.dumps([args.connect]))
            config.insert_json5("listen/endpoints", json.dumps([OWN_LISTEN]))
            config.insert_json5("scouting/multicast/enabled", "false")
    except Exception as e:  # zenoh raises its own ZError
        flag = "--config" if args.config else "--connect"
        print(f"error: {flag} {args.connect}: {' '.join(str(e).split())}", file=sys.stderr)
        return 1

    received = 0
    with zenoh.open(config) as session:
        # A ring channel keeps only the newest forecasts: a slow script never holds zenoh up.
        subscriber = session.declare_subscriber(args.key, zenoh.handlers.RingChannel(4))
        print(f"listening on {args.key} via {args.connect}", file=sys.stderr)
        # Said at once when the predictor is not there (a wrong endpoint, a stopped pipeline)
        # rather than waiting in silence.
        alive = f"{args.key}/alive"
        replies = session.liveliness().get(alive, timeout=ALIVE_PATIENCE_S)
        if not any(getattr(reply, "ok", None) is not None for reply in replies):
            print(f"no predictor heard on {alive} after {ALIVE_PATIENCE_S:.0f} s (is it running, "
                  "and is this its endpoint?): waiting for it", file=sys.stderr)
        try:
            while args.count == 0 or received < args.count:
                sample = subscriber.recv()
                try:
                    forecast, k20 = forecast_at(sample.payload.to_bytes(), 20.0)
                except ValueError as why:
                    print(f"skipped a message: {why}", file=sys.stderr)
                    continue
                received += 1
                dt = forecast["dt_s"]
                heave = forecast["mean"][2][k20]
                heave_sigma = forecast["sigma"][2][k20]
                roll = math.degrees(forecast["mean"][3][k20])
                print(f"seq {forecast['seq']} t={forecast['time_s']:.1f}s model v{forecast['model_version']}: "
                      f"in {(k20 + 1) * dt:.1f} s heave {heave:+.2f} m (sigma {heave_sigma:.2f}), "
                      f"roll {roll:+.1f} deg  [{sample.encoding}]")
        except KeyboardInterrupt:
            pass
    return 0


if __name__ == "__main__":
    sys.exit(main())

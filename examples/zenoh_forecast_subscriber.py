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
import time

import zenoh


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

    if args.config:
        config = zenoh.Config.from_file(args.config)
        args.connect = args.config
    else:
        config = zenoh.Config()
        config.insert_json5("mode", '"peer"')
        config.insert_json5("connect/endpoints", json.dumps([args.connect]))
        config.insert_json5("scouting/multicast/enabled", "false")

    received = 0
    with zenoh.open(config) as session:
        # A ring channel keeps only the newest forecasts: a slow script never holds zenoh up.
        subscriber = session.declare_subscriber(args.key, zenoh.handlers.RingChannel(4))
        print(f"listening on {args.key} via {args.connect}", file=sys.stderr)
        try:
            while args.count == 0 or received < args.count:
                sample = subscriber.recv()
                forecast = json.loads(sample.payload.to_bytes())
                received += 1
                steps = forecast["steps"]
                dt = forecast["dt_s"]
                k20 = min(steps, round(20.0 / dt)) - 1
                heave = forecast["mean"][2][k20]
                heave_sigma = forecast["sigma"][2][k20]
                roll = math.degrees(forecast["mean"][3][k20])
                print(f"seq {forecast['seq']} t={forecast['time_s']:.1f}s model v{forecast['model_version']}: "
                      f"in {(k20 + 1) * dt:.0f} s heave {heave:+.2f} m (sigma {heave_sigma:.2f}), "
                      f"roll {roll:+.1f} deg  [{sample.encoding}]")
        except KeyboardInterrupt:
            pass
    return 0


if __name__ == "__main__":
    sys.exit(main())

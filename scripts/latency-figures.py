#!/usr/bin/env python3
"""The capture -> CAN command figures from saccade's --stats-json files:
one_process.json (graphs/head_loop.xml) and robot_pc.json (graphs/two_pc.xml's
robot PC); a Markdown table on stdout, and each floor met or not."""
import json
import sys

PERIOD_MS = 4.0  # the driver's default rate, 250 Hz


def timing(stats, node, name):
    for n in stats["nodes"]:
        if n["name"] == node:
            return n.get("timings_ns", {}).get(name)
    return None


def row(label, t):
    if not t or t["count"] == 0:
        return f"| {label} | 0 | | | | |", None
    ms = lambda v: v / 1e6
    return (f"| {label} | {t['count']} | {ms(t['p50']):.3f} | {ms(t['p99']):.3f} | {ms(t['mean']):.3f} | "
            f"{ms(t['max']):.3f} |", ms(t["p50"]))


def main():
    if len(sys.argv) != 3:
        sys.exit("usage: latency-figures.py one_process.json robot_pc.json")
    one, two = (json.load(open(p)) for p in sys.argv[1:])
    print("| where | requests | p50 ms | p99 ms | mean ms | max ms |")
    print("|---|---|---|---|---|---|")
    lines = [
        ("one process: camera frame -> head takes the request", one, "head", "gaze_capture_to_taken", None),
        ("**one process: camera frame -> CAN set-points**", one, "driver", "gaze_capture_to_command", 0.5),
        ("two processes: camera frame -> head takes the request", two, "head", "gaze_capture_to_taken", None),
        ("**two processes: camera frame -> CAN set-points**", two, "driver", "gaze_capture_to_command",
         PERIOD_MS + 0.5),
    ]
    verdicts = []
    for label, stats, node, name, floor in lines:
        text, p50 = row(label, timing(stats, node, name))
        print(text)
        if floor is not None:
            met = p50 is not None and p50 <= floor
            verdicts.append(f"{label.strip('*')}: p50 {p50 if p50 is None else round(p50, 3)} ms, floor {floor} ms: "
                            + ("met" if met else "NOT met"))
    print()
    for v in verdicts:
        print("- " + v)


if __name__ == "__main__":
    main()

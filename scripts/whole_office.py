#!/usr/bin/env python3
"""The whole office, timed end to end (issue 20, item 5): the four positions SO-1 ... SO-4 simulated,
tracked, fused into panoramas, registered, placed by the pose graph, integrated into one cloud and
evaluated against the ground-truth mesh, at the tables' full size (640x480 cameras, every 16th frame,
panoramas at H = 1024; `panoscan tables` calls it "full").

  /usr/bin/python3 scripts/whole_office.py [--build build] [--out DIR] [--threads 0] [--noise handa]
                                           [--every 16] [--height 1024] [--seed 1] [--keep]
                                           [--set KEY=VALUE ...]

Writes DIR/whole_office.json and DIR/whole_office.md: wall-clock seconds of every stage (the simulator's
per position; tracking, panoramas, registration, pose graph and integration from `recon scene`'s
timings.json; the evaluation), the total, and the cloud's RMSE so that a faster run can be checked to be
as accurate. Scans and clouds are written under DIR/work and removed afterwards unless --keep. Each
--set is passed to `recon scene` (e.g. --set frontend.orb_levels=3) and recorded in the settings.
"""

import argparse
import datetime
import json
import os
import shutil
import subprocess
import sys
import time

from speed_report import cpu_model  # the same machine line as the speed report

POSITIONS = ["SO-1", "SO-3", "SO-2", "SO-4"]  # neighbours next to each other (Table 5's order)


def run(command, log):
    start = time.monotonic()
    result = subprocess.run(command, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    seconds = time.monotonic() - start
    log.write("$ " + " ".join(command) + "\n" + result.stdout + "\n")
    if result.returncode != 0:
        sys.exit(f"whole_office.py: {' '.join(command)} failed with exit {result.returncode}:\n{result.stdout[-2000:]}")
    return seconds


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--build", default="build")
    parser.add_argument("--out", default="whole-office")
    parser.add_argument("--threads", type=int, default=0)
    parser.add_argument("--noise", default="handa")
    parser.add_argument("--every", type=int, default=16)
    parser.add_argument("--height", type=int, default=1024)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--keep", action="store_true")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                        help="a config key for recon scene (repeatable)")
    args = parser.parse_args()

    panoscan = os.path.join(args.build, "app", "panoscan")
    if not os.path.exists(panoscan):
        sys.exit(f"whole_office.py: {panoscan} not found (build first)")
    version = subprocess.run([panoscan, "--version"], capture_output=True, text=True).stdout.strip()
    work = os.path.join(args.out, "work")
    shutil.rmtree(work, ignore_errors=True)
    os.makedirs(work)
    threads = ["--threads", str(args.threads)]
    stages = []
    with open(os.path.join(args.out, "whole_office.log"), "w") as log:
        scans = []
        for name in POSITIONS:
            scan = os.path.join(work, name)
            seconds = run([panoscan, "sim", "--scene", "office", "--position", name, "--every", str(args.every),
                           "--noise", args.noise, "--set", f"seed={args.seed}", "--out", scan] + threads, log)
            stages.append({"stage": f"sim {name}", "seconds": seconds})
            scans.append(scan)
        scene = os.path.join(work, "scene")
        seconds = run([panoscan, "recon", "scene", "--scans"] + scans +
                      ["--out", scene, "--align-to-ground-truth", "--set", f"panorama.height={args.height}",
                       "--set", f"seed={args.seed}"] + [a for kv in args.set for a in ("--set", kv)] + threads,
                      log)
        with open(os.path.join(scene, "timings.json")) as f:
            timings = json.load(f)
        with open(os.path.join(scene, "registrations.json")) as f:
            pairs = json.load(f)
        parts = [("tracking", "tracking_s"), ("panoramas (warp + TSA-L1)", "panorama_s"),
                 ("registration (ORB guess + GICP)", "registration_s"), ("pose graph", "pose_graph_s"),
                 ("integration (MAP)", "integration_s")]
        accounted = 0.0
        for label, key in parts:
            stages.append({"stage": label, "seconds": timings[key]})
            accounted += timings[key]
        # Reading the scans, writing the cloud and the panoramas: the rest of the command's time.
        stages.append({"stage": "recon scene: reading and writing", "seconds": max(0.0, seconds - accounted)})
        report = os.path.join(work, "eval.json")
        seconds = run([panoscan, "eval", "cloud", "--cloud", os.path.join(scene, "cloud.ply"), "--scan", scans[0],
                       "--json", report] + threads, log)
        stages.append({"stage": "evaluation against the mesh", "seconds": seconds})
        with open(report) as f:
            evaluation = json.load(f)
    total = sum(s["seconds"] for s in stages)
    record = {
        "date": datetime.datetime.utcnow().strftime("%Y-%m-%d %H:%M UTC"),
        "machine": f"{cpu_model()}, {os.cpu_count()} hardware threads",
        "built_from": version,
        "command": " ".join([sys.executable] + sys.argv),
        "settings": {"positions": POSITIONS, "width": 640, "height": 480, "every": args.every,
                     "panorama_height": args.height, "noise": args.noise, "seed": args.seed,
                     "threads": args.threads, "recon_scene_settings": args.set},
        "stages": stages,
        "total_s": total,
        "evaluation": evaluation,
        "registrations": {"kept": [f"{p['source']} -> {p['target']}" for p in pairs["kept"]],
                          "runner_ups_dismissed": sum(1 for p in pairs["kept"]
                                                      if p["runner_up"] and p["runner_up"]["dismissed"]),
                          "skipped": pairs["skipped"]},
    }
    with open(os.path.join(args.out, "whole_office.json.tmp"), "w") as f:
        json.dump(record, f, indent=2)
        f.write("\n")
    os.replace(os.path.join(args.out, "whole_office.json.tmp"), os.path.join(args.out, "whole_office.json"))
    rmse = evaluation.get("accuracy", {}).get("rmse_mm")
    lines = [f"# The whole office end to end, {record['date']}", "",
             f"Machine: {record['machine']}. Built from: {version}. Command: `{record['command']}`.", "",
             f"Four positions ({', '.join(POSITIONS)}), 640x480, every {args.every}th frame, panoramas at "
             f"H = {args.height}, {args.noise} noise, seed {args.seed}" +
             (f"; recon scene with {', '.join(args.set)}." if args.set else "."), "",
             "| stage | seconds | share |", "|---|---:|---:|"]
    for s in stages:
        lines.append(f"| {s['stage']} | {s['seconds']:.1f} | {100 * s['seconds'] / total:.0f}% |")
    lines.append(f"| **total** | **{total:.1f}** | |")
    lines.append("")
    lines.append(f"Cloud RMSE against the mesh (accuracy): {rmse:.2f} mm, "
                 f"{evaluation['accuracy']['count']} points." if rmse is not None else
                 "Cloud RMSE: see whole_office.json (evaluation).")
    regs = record["registrations"]
    lines.append(f"Registrations: {len(regs['kept'])} kept ({regs['runner_ups_dismissed']} with a weak runner-up "
                 f"dismissed), {len(regs['skipped'])} skipped" +
                 "".join(f"\n- skipped: {reason}" for reason in regs["skipped"]))
    with open(os.path.join(args.out, "whole_office.md"), "w") as f:
        f.write("\n".join(lines) + "\n")
    print("\n".join(lines))
    if not args.keep:
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()

#!/usr/bin/python3
"""Samples nodes' CPU and RSS from /proc and keeps their newest /diagnostics statuses while a
benchmark runs (scripts/bench_network.sh, scripts/bench_soak.sh).

  bench_monitor.py --pid calibration=1234 --pid correction=1235 --wait-pid <publisher pid>
                   --interval 5 --csv out.csv --json out.json [--settle 10]

Stops when --wait-pid has exited plus --settle s (the nodes drain their queues). Writes one CSV
row per interval (wall s, per pid: RSS kB and CPU s) and a JSON summary: per pid the CPU used
while the publisher ran (fraction of one core), CPU s over the whole run, RSS first/min/max/last
and the RSS growth over the second half of the run; and every diagnostics status of the monitored
nodes (name -> values).

With --clock (replays with /use_sim_time, scripts/bench_replay.sh): /clock is followed while the
publisher (rosbag play --clock) runs, and the summary's "clock" gives the wall time between the
first and last /clock message and the replay rate achieved (sim s per wall s; late when this
monitor is starved of CPU: publisher_wall_s, from the monitor's start to the publisher's exit
seen at --interval, and publisher_end_time, UNIX s, do not depend on it); after the
publisher exits, /clock is advanced by 1 s every 0.05 wall s during --settle so that the nodes'
ROS-time timers (diagnostics) keep reporting their final counters.
"""
import argparse
import json
import os
import sys
import time

import rospy
from diagnostic_msgs.msg import DiagnosticArray

TICKS = os.sysconf("SC_CLK_TCK")


def proc_sample(pid):
    try:
        with open("/proc/%d/stat" % pid) as f:
            fields = f.read().rsplit(")", 1)[1].split()
        cpu = (int(fields[11]) + int(fields[12])) / TICKS  # utime + stime
        rss = 0
        with open("/proc/%d/status" % pid) as f:
            for line in f:
                if line.startswith("VmRSS:"):
                    rss = int(line.split()[1])
        return cpu, rss
    except (OSError, IndexError, ValueError):
        return None


def alive(pid):
    try:
        os.kill(pid, 0)
        return True
    except OSError:
        return False


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--pid", action="append", default=[], help="name=pid")
    ap.add_argument("--wait-pid", type=int, required=True)
    ap.add_argument("--interval", type=float, default=5.0)
    ap.add_argument("--settle", type=float, default=10.0)
    ap.add_argument("--csv", required=True)
    ap.add_argument("--json", required=True)
    ap.add_argument("--status-prefix", action="append", default=[], help="diagnostics name prefix to keep")
    ap.add_argument("--clock", action="store_true", help="follow /clock, advance it after the publisher exits")
    args = ap.parse_args(rospy.myargv()[1:])
    pids = {n: int(p) for n, p in (x.split("=", 1) for x in args.pid)}

    statuses = {}

    def on_diag(msg):
        for s in msg.status:
            if not args.status_prefix or any(s.name.startswith(p) for p in args.status_prefix):
                statuses[s.name] = {"level": int(s.level), "message": s.message,
                                    **{kv.key: kv.value for kv in s.values}}

    rospy.init_node("bench_monitor", anonymous=True, disable_signals=True)
    rospy.Subscriber("/diagnostics", DiagnosticArray, on_diag, queue_size=1000)
    clock = {}
    clock_pub = None
    if args.clock:
        from rosgraph_msgs.msg import Clock

        def on_clock(msg):
            if clock.get("advancing"):
                return
            now, sim = time.time(), msg.clock.to_sec()
            if "first_wall" not in clock or sim == clock["first_sim"]:  # a held start (play delay) is not counted
                clock.update(first_wall=now, first_sim=sim)
            clock.update(last_wall=now, last_sim=sim)

        rospy.Subscriber("/clock", Clock, on_clock, queue_size=10000)
        clock_pub = rospy.Publisher("/clock", Clock, queue_size=10)

    rows = []
    t0 = time.time()
    publisher_end = None
    csv = open(args.csv, "w")
    csv.write("wall_s," + ",".join("%s_rss_kB,%s_cpu_s" % (n, n) for n in pids) + "\n")
    while True:
        now = time.time()
        sample = {n: proc_sample(p) for n, p in pids.items()}
        for n, p in pids.items():  # the publisher may be monitored too: after it exits, its last sample
            if sample[n] is None and p == args.wait_pid and rows:
                sample[n] = rows[-1][1][n]
        if any(v is None for v in sample.values()):
            print("bench_monitor: a node exited", sample, file=sys.stderr)
            break
        rows.append((now - t0, sample))
        csv.write("%.1f," % (now - t0) + ",".join("%d,%.2f" % (v[1], v[0]) for v in sample.values()) + "\n")
        csv.flush()
        if publisher_end is None and not alive(args.wait_pid):
            publisher_end = now
        if publisher_end is not None and now - publisher_end >= args.settle:
            break
        if clock_pub is not None and publisher_end is not None:
            clock["advancing"] = True
            sim = clock.get("last_sim", 0.0)
            until = min(now + args.interval, publisher_end + args.settle)
            while time.time() < until:
                sim += 1.0
                clock_pub.publish(Clock(clock=rospy.Time.from_sec(sim)))
                time.sleep(0.05)
            clock["last_sim_advanced"] = sim
            continue
        time.sleep(args.interval)

    summary = {"wall_s": time.time() - t0, "nodes": {}, "diagnostics": statuses,
               "publisher_wall_s": None if publisher_end is None else publisher_end - t0,
               "publisher_end_time": publisher_end}
    if args.clock and "first_wall" in clock:
        span = clock["last_wall"] - clock["first_wall"]
        summary["clock"] = {"wall_s": span, "sim_s": clock["last_sim"] - clock["first_sim"],
                            "rate": (clock["last_sim"] - clock["first_sim"]) / span if span > 0 else None,
                            "first_sim": clock["first_sim"], "last_sim": clock["last_sim"]}
    run = [r for r in rows if publisher_end is None or r[0] <= publisher_end - t0 + args.interval]
    for n in pids:
        series = [(t, s[n]) for t, s in rows]
        rss = [v[1] for _, v in series]
        half = len(series) // 2
        first_run, last_run = run[0], run[-1]
        cpu = (last_run[1][n][0] - first_run[1][n][0]) / max(1e-9, last_run[0] - first_run[0])
        summary["nodes"][n] = {
            "cpu_fraction_of_one_core": cpu,
            "cpu_s_total": series[-1][1][0] - series[0][1][0],
            "rss_kB_first": rss[0], "rss_kB_min": min(rss), "rss_kB_max": max(rss), "rss_kB_last": rss[-1],
            "rss_kB_growth_second_half": rss[-1] - rss[half] if half < len(rss) else 0,
            "samples": len(rss),
        }
    with open(args.json, "w") as f:
        json.dump(summary, f, indent=1, sort_keys=True)
    rospy.signal_shutdown("done")


if __name__ == "__main__":
    main()

"""One process per FLS over 4 network-namespace hosts: simple discovery beside the server.

The `hosts` section of BENCHMARKS.md (`python -m bench --sections hosts`).
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import subprocess
import sys
from functools import partial
from pathlib import Path
from typing import Any

from bench.common import REPO, SECTIONS_DIR, table_cell

#: The hosts section: FLS processes over this many network-namespace hosts, at these sizes.
HOSTS = 4


HOST_SIZES = (25, 50, 100, 200)


#: At this size each mode also computes every blind pair and runs the faults.
CHECKED_SIZE = 100


def hosts_section(
    args: argparse.Namespace,
    sizes: tuple[int, ...] = HOST_SIZES,
    hosts: int = HOSTS,
    discoveries: tuple[str, ...] = ("server", "simple"),
    figures: Path = REPO / "docs" / "figures",
    records_dir: Path = SECTIONS_DIR,
    prefix: str = "swzbench",
) -> list[str]:
    """One process per FLS over 4 network-namespace hosts: simple discovery beside the server."""
    title = "## One process per FLS across hosts"
    script = REPO / "scripts" / "netns_hosts.sh"
    if os.geteuid() != 0 or shutil.which("ip") is None:
        return [title, "", "Skipped: network namespaces need root and iproute2."]
    env = dict(os.environ, SWAZURE_NETNS_PREFIX=prefix)
    env.pop("ROS_AUTOMATIC_DISCOVERY_RANGE", None)
    subprocess.run([str(script), "up", str(hosts)], env=env, check=True, capture_output=True)
    records: list[dict[str, Any]] = []
    try:
        for flss in sizes:
            for discovery in discoveries:
                out = records_dir / f"hosts-{flss}-{discovery}.json"
                extra = ["--compute-all", "--faults"] if flss == CHECKED_SIZE else []
                print(f"bench: hosts, {flss} FLS processes, {discovery} discovery", flush=True)
                command = [str(script), "exec", "0", sys.executable,
                           "-m", "bench.measure_hosts", "--flss", str(flss),
                           "--hosts", str(hosts), "--discovery", discovery,
                           "--out", str(out), *extra]  # fmt: skip
                try:
                    subprocess.run(command, env=env, timeout=1800, capture_output=True, cwd=REPO)
                    records.append(json.loads(out.read_text()))
                except (subprocess.TimeoutExpired, OSError, ValueError) as err:
                    records.append({"flss": flss, "discovery": discovery, "stopped": str(err)})
    finally:
        subprocess.run([str(script), "down"], env=env, capture_output=True)
    hosts_figures(records, figures)
    return hosts_lines(records)


def hosts_lines(records: list[dict[str, Any]]) -> list[str]:
    """The hosts section's tables from the bench.measure_hosts records."""
    lines = [
        "## One process per FLS across hosts",
        "",
        f"`swazure spawn --per-fls --share K/{HOSTS}` on each of {HOSTS} network-namespace",
        "hosts (scripts/netns_hosts.sh; run by bench/measure_hosts.py): the built-in torus",
        "of N FLSs (`torus:N`, which makes 24, 48, 102 and 200 FLSs for N = 25, 50, 100,",
        "200; scale 1.6, beta 0.5: 11 cm across, inside the sensor's reach of 30.6 cm, so",
        "every FLS's radio cells hold every other FLS), every FLS a process of its own,",
        "host 0 also runs the simulator and the coordinator. Bring-up: from the first",
        "launcher's start until host 0 sees every FLS and every host's radio is matched by",
        "the coordinator (an FLS takes part in rounds once its radio cells' readers are",
        "matched, or after its `join_timeout`). Memory: resident",
        "(Rss) per FLS process; total: proportional (Pss: shared library pages counted",
        "once) over every process. Idle: 10 s after bring-up, CPU cores used by every",
        "process of the swarm; traffic: what the hosts sent on their links.",
        "",
        "| FLS processes | discovery | bring-up s | bring-up CPU s | CPU s per FLS process "
        "| FLS process MB | total GB (Pss) | idle CPU cores | bring-up packets | bring-up MB "
        "| idle packets/s | idle kB/s | every blind pair as the engine |",
        "| ---: | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: "
        "| --- |",
    ]
    lines += [hosts_row(record) for record in records]
    lines += hosts_faults_lines(records)
    lines += [
        "",
        "Targets (issue 56): 200 FLS processes up and matched in under 90 s through the "
        "server, with bring-up CPU per FLS process flat from 25 to 200. On this machine "
        "bring-up is bound by its two cores (bring-up CPU s above): every FLS process costs "
        "seconds of CPU to start and discover, where a real FLS has a computer of its own; "
        "and on a shape inside the sensor's reach every FLS hears every other, so each "
        "process still matches every other's radio endpoints. docs/swarm.md reads the table.",
        "",
        "Figures: docs/figures/hosts-bringup.png, docs/figures/hosts-traffic.png, "
        "docs/figures/hosts-cpu.png.",
    ]
    return lines


def hosts_row(record: dict[str, Any]) -> str:
    """One row of the hosts table: a swarm up, or where its bring-up stopped."""
    count = record.get("fls_processes", record["flss"])
    if "bring_up_s" not in record:
        stopped = record.get("stopped", "?").replace("|", "/")
        # Memory and CPU at the stop count only if every FLS process was still there.
        whole = record.get("fls_processes") == record["flss"]
        return (
            f"| {record['flss']} | {record['discovery']} | {stopped} "
            f"| {table_cell(record, 'cpu_s', '.0f') if whole else '-'} | - | - "
            f"| {table_cell(record, 'total_pss_mb', '.2f', 1e-3) if whole else '-'} | - "
            f"| {record.get('stopped_packets', '-')} "
            f"| {table_cell(record, 'stopped_bytes', '.1f', 1e-6)} | - | - | - |"
        )
    identical = record.get("identical", "-")
    if "pairs" in record:
        identical = f"{identical} ({record['pairs']} pairs, {record['discovery_s']:.1f} s)"
    return (
        f"| {count} | {record['discovery']} | {record['bring_up_s']:.1f} "
        f"| {table_cell(record, 'bring_up_cpu_s', '.0f')} "
        f"| {table_cell(record, 'bring_up_cpu_s', '.2f', 1 / count)} "
        f"| {table_cell(record, 'fls_rss_mb_mean', '.0f')} "
        f"| {table_cell(record, 'total_pss_mb', '.2f', 1e-3)} "
        f"| {table_cell(record, 'idle_cpu_cores', '.2f')} "
        f"| {record['bring_up_packets']} | {record['bring_up_bytes'] / 1e6:.1f} "
        f"| {table_cell(record, 'idle_packets_per_s', '.0f')} "
        f"| {table_cell(record, 'idle_bytes_per_s', '.1f', 1e-3)} | {identical} |"
    )


def hosts_faults_lines(records: list[dict[str, Any]]) -> list[str]:
    """The faults table of the records that ran them; none when none did."""
    lines: list[str] = []
    faults = [
        (record, kind) for record in records for kind in ("fault_fls", "fault_server")
        if kind in record
    ]  # fmt: skip
    if faults:
        lines += [
            "",
            f"Faults at {CHECKED_SIZE} FLS processes, each in a discovery run of every blind "
            "pair: 5 % of the FLS processes killed (SIGKILL, no goodbye) 0.5 s into the run; "
            "then the Discovery Server killed 0.5 s into the next run. Detection: from the "
            "kill until the coordinator counts every killed FLS departed. Right: every pair "
            "of two living FLSs has the engine's status, path and estimate (1e-9 cm) on the "
            "shape without the dead.",
            "",
            "| discovery | fault | killed | run s | restarts | detection s | departed "
            "| living pairs right |",
            "| --- | --- | --- | ---: | ---: | ---: | --- | --- |",
        ]
        for record, kind in faults:
            fault = record[kind]
            what = "server killed" if fault["server_killed"] else "5 % of FLSs killed"
            detection = fault["detection_s"] if fault["killed"] else None
            lines.append(
                f"| {record['discovery']} | {what} | {fault['killed'] or '-'} "
                f"| {fault['seconds']:.1f} | {fault['restarts']} "
                f"| {'-' if detection is None else f'{detection:.1f}'} "
                f"| {fault['departed'] or '-'} | {fault['identical']} "
                f"({fault['pairs'] - fault['wrong'] - fault['missing']} of {fault['pairs']}) |"
            )
        after = [r["gone_30s_after_server"] for r in records if "gone_30s_after_server" in r]
        if after:
            lines += ["", f"FLSs the coordinator took for gone in the 30 s after the server "
                      f"was killed: {after[0] or 'none'}."]  # fmt: skip
    return lines


def hosts_figures(records: list[dict[str, Any]], folder: Path) -> None:
    """Bring-up time and bring-up traffic against the number of FLS processes, as PNGs.

    A bring-up that did not end by its deadline is drawn hollow: at the deadline
    in the time figure, with what had been sent by then in the traffic figure.
    """
    from matplotlib.figure import Figure

    from swazure_ros.files.atomic import atomic_write

    def deadline(record: dict[str, Any]) -> float | None:
        found = re.search(r"after ([0-9.]+) s", record.get("stopped", ""))
        return float(found[1]) if found else None

    # CPU per FLS process: at bring-up, or by the deadline when every process was there.
    records = [dict(record) for record in records]
    for record in records:
        if "bring_up_cpu_s" in record:
            record["cpu_per_fls"] = record["bring_up_cpu_s"] / record["fls_processes"]
        elif "cpu_s" in record and record.get("fls_processes") == record["flss"]:
            record["stopped_cpu_per_fls"] = record["cpu_s"] / record["flss"]
    for name, key, stopped_key, scale, label in (
        ("hosts-bringup.png", "bring_up_s", None, 1.0, "bring-up (s)"),
        ("hosts-traffic.png", "bring_up_bytes", "stopped_bytes", 1e-6,
         "sent by the hosts during bring-up (MB)"),
        ("hosts-cpu.png", "cpu_per_fls", "stopped_cpu_per_fls", 1.0,
         "bring-up CPU per FLS process (s)"),
    ):  # fmt: skip
        figure = Figure(figsize=(6.4, 4.2), layout="constrained")
        axes = figure.subplots()
        for discovery, marker, colour in (("server", "o", "C0"), ("simple", "s", "C1")):
            mine = [r for r in records if r.get("discovery") == discovery]
            done = [r for r in mine if key in r]
            title = "Discovery Server" if discovery == "server" else "simple discovery"
            axes.plot([r["fls_processes"] for r in done], [r[key] * scale for r in done],
                      marker=marker, color=colour, label=title)  # fmt: skip
            for record in mine:
                if key in record:
                    continue
                value = deadline(record) if stopped_key is None else record.get(stopped_key)
                if value is None:
                    continue
                x, y = record["flss"], value * scale
                axes.plot([x], [y], marker=marker, color=colour, markerfacecolor="none",
                          markersize=9, linestyle="none")  # fmt: skip
                what = (f"not up after {deadline(record):g} s" if stopped_key is None
                        else "until the deadline")  # fmt: skip
                below = discovery == "simple"
                axes.annotate(what, (x, y), textcoords="offset points", fontsize=8,
                              xytext=(-120, -14 if below else 8), color=colour)  # fmt: skip
        if key == "bring_up_s":
            axes.axhline(90, color="grey", linewidth=0.8, linestyle=":")
            axes.annotate("90 s target", (axes.get_xlim()[0], 90), textcoords="offset points",
                          xytext=(4, 3), color="grey", fontsize=8)  # fmt: skip
        axes.set_xlabel(f"FLS processes over {HOSTS} hosts (2 cores)")
        axes.set_ylabel(label)
        axes.set_ylim(bottom=0, top=axes.get_ylim()[1] * 1.08)
        axes.grid(True, alpha=0.3)
        axes.legend(loc="upper left")
        figure.suptitle(f"One process per FLS: {label.split(' (')[0]}; hollow: stopped")
        atomic_write(folder / name, partial(figure.savefig, format="png", dpi=110))

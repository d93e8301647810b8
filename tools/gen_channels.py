#!/usr/bin/env python3
"""Generate afm_channels.h from lcmtypes/channels.yaml (the one definition of the bus's channels)."""
import re
import sys

import yaml


def programs(text: str, field: str = "publisher"):
    """channels.yaml's publisher or readers field as program names:
    "renderer, operator (planner)" -> renderer, operator; "every process" -> *;
    "none" -> none."""
    if text.strip() == "every process":
        return ["*"]
    if text.strip() == "none":
        return []
    out = [re.sub(r"\(.*?\)", "", p).strip() for p in text.split(",")]
    if not all(re.fullmatch(r"[a-z_]+", p) for p in out):
        raise SystemExit(f"channels.yaml: {field} {text!r} is not a list of program names")
    return out


def main(src: str, dst: str) -> int:
    with open(src) as f:
        rows = yaml.safe_load(f)
    lines = ["/* Generated from lcmtypes/channels.yaml by tools/gen_channels.py. Do not edit. */",
             "#ifndef AFM_CHANNELS_H", "#define AFM_CHANNELS_H", ""]
    for r in rows:
        ch = r["channel"]
        if "readers" not in r:
            raise SystemExit(f"channels.yaml: {ch}: no readers (name them, or none)")
        lines.append(f"/* {r['type']}, published by {r['publisher']}, read by {r['readers']}, {r['rate']} */")
        lines.append(f'#define AFM_CH_{ch} "{ch}"')
    lines.append("")
    lines.append("#define AFM_CHANNEL_COUNT %d" % len(rows))
    lines.append("#define AFM_CHANNEL_LIST { %s }" % ", ".join(f'"{r["channel"]}"' for r in rows))
    lines.append("/* X(CHANNEL, type) for every channel: the type each one carries. */")
    lines.append("#define AFM_CHANNEL_TYPES(X) %s" % " ".join(f'X({r["channel"]}, {r["type"]})' for r in rows))
    lines.append("/* X(\"CHANNEL\", \"program\") for each program that publishes a channel (\"*\": every")
    lines.append("   process of the run): the senders a receiver admits (bus/senders.hpp). */")
    lines.append("#define AFM_CHANNEL_PUBLISHERS(X) %s" % " ".join(f'X("{r["channel"]}", "{p}")' for r in rows
                                                             for p in programs(r["publisher"])))
    lines.append("/* X(\"CHANNEL\", \"program\") for each program of the run that subscribes to a channel")
    lines.append("   (\"*\": every process): a process's declared subscriptions (bus/run_process.hpp). */")
    lines.append("#define AFM_CHANNEL_READERS(X) %s" % " ".join(f'X("{r["channel"]}", "{p}")' for r in rows
                                                          for p in programs(r["readers"], "readers")))
    lines += ["", "#endif", ""]
    with open(dst, "w") as f:
        f.write("\n".join(lines))
    return 0


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit("usage: gen_channels.py channels.yaml afm_channels.h")
    sys.exit(main(sys.argv[1], sys.argv[2]))

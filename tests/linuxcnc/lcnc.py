#!/usr/bin/python3
"""Drives a running headless LinuxCNC through its Python module (Debian's /usr/bin/python3) for
mlprobe's controller tests (docs/HOSTD.md, ../shared/LINUXCNC.md):

  lcnc.py run PROGRAM [TIMEOUT_S]   estop reset, machine on, home, run PROGRAM to its end
  lcnc.py state                     the live state only

Prints one JSON object: the error channel's messages, the interpreter's end, the tool table
(by tool id, the spindle slot left out), G5x offset, tool offset, position (and every axis and
joint), tool in spindle.
HOME must be the LinuxCNC process's HOME (the tool table is shared through $HOME/.tool.mmap)."""
import json
import sys
import time

import linuxcnc


def wait(stat, predicate, timeout_s):
    end = time.time() + timeout_s
    while time.time() < end:
        stat.poll()
        if predicate():
            return True
        time.sleep(0.02)
    return False


def state(stat, errors):
    stat.poll()
    tools = {}
    for i, t in enumerate(stat.tool_table):
        if i == 0 or t.id < 0:  # entry 0 is the spindle slot; id -1 is empty
            continue
        tools[str(t.id)] = {"x": t.xoffset, "y": t.yoffset, "z": t.zoffset, "c": t.coffset,
                            "diameter": t.diameter}
    return {
        "errors": errors,
        "tools": tools,
        "g5x_offset": list(stat.g5x_offset[:3]),
        "g5x_rotation": stat.rotation_xy,
        "tool_offset": list(stat.tool_offset[:3]),
        "position": list(stat.position[:3]),
        # Five-axis machines: every axis' position (X Y Z A B C U V W; in the table's frame under
        # a table kinematics with TCP) and the joints (the machine's own coordinates).
        "axes": list(stat.position[:9]),
        "joints": list(stat.joint_actual_position[:stat.joints]),
        "tool_in_spindle": stat.tool_in_spindle,
    }


def drain(channel):
    out = []
    while True:
        m = channel.poll()
        if not m:
            return out
        out.append(m[1])


def run(program, timeout_s):
    stat, command, channel = linuxcnc.stat(), linuxcnc.command(), linuxcnc.error_channel()
    command.state(linuxcnc.STATE_ESTOP_RESET)
    command.state(linuxcnc.STATE_ON)
    command.wait_complete()
    stat.poll()
    if not all(stat.homed[:3]):
        command.home(-1)
        command.wait_complete()
        if not wait(stat, lambda: all(stat.homed[:3]), 60):  # instant in sim; 60 s under load
            raise SystemExit("not homed")
    drain(channel)
    command.mode(linuxcnc.MODE_AUTO)
    command.wait_complete()
    command.program_open(program)
    command.auto(linuxcnc.AUTO_RUN, 0)
    # Task acknowledges the run once it has set the interpreter reading: from then on "idle"
    # means the program ended (no guess at how long it takes to start on a busy machine).
    if command.wait_complete(60) == -1:
        raise SystemExit("LinuxCNC did not take the run command within 60 s")
    ended = wait(stat, lambda: stat.interp_state == linuxcnc.INTERP_IDLE and stat.queue == 0,
                 timeout_s)
    time.sleep(0.2)  # the error channel's last message
    result = state(stat, drain(channel))
    result["ended"] = ended
    return result


def main():
    if len(sys.argv) >= 3 and sys.argv[1] == "run":
        timeout_s = float(sys.argv[3]) if len(sys.argv) > 3 else 60.0
        print(json.dumps(run(sys.argv[2], timeout_s)))
    elif len(sys.argv) == 2 and sys.argv[1] == "state":
        print(json.dumps(state(linuxcnc.stat(), [])))
    else:
        raise SystemExit(__doc__)


if __name__ == "__main__":
    main()

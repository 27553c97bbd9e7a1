#!/usr/bin/env python3
"""Wire a deployment session to a rig through pipes: the shape of a lab's
glue code between `tdeploy session serve` (the controller) and the motors
and data acquisition (here `tdeploy rig`, a simulated bridge). Standard
library only.

    tdeploy session start -o lab/s1
    python3 examples/rig_client.py lab/s1 -- --seed 3

Everything after `--` goes to `tdeploy rig` (e.g. `--truth T.toml --seed
S`). Messages are JSON lines (protocol tensegrity-deploy/session-protocol/1,
docs/session.md): the controller's `command` goes to the rig as it is; the
rig's `measurements` go back to the controller as they are; the rig's
`truth` messages (what only a simulator knows) are printed. With approval
required, each command is approved here after `--approve-all`, else asked
on the terminal.

Exit 0 when the session ends connected and the simulated truth broke no
limit, 1 when it ends otherwise (or connected with a truth limit broken) or
an interlock stops it, 2 on a protocol error. `--summary FILE` writes the
commands, the true gaps and the truth's violations as JSON.
"""

import argparse
import json
import subprocess
import sys

PROTOCOL = "tensegrity-deploy/session-protocol/1"


def fail(message):
    """A protocol error: say it and exit 2."""
    print(f"rig_client: {message}", file=sys.stderr)
    sys.exit(2)


class Peer:
    """A child process speaking JSON lines."""

    def __init__(self, name, argv):
        self.name = name
        self.proc = subprocess.Popen(
            argv, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True, bufsize=1
        )

    def read(self):
        line = self.proc.stdout.readline()
        if not line:
            code = self.proc.wait()
            fail(f"{self.name} closed its output (exit {code})")
        return line, json.loads(line)

    def send(self, line):
        self.proc.stdin.write(line.rstrip("\n") + "\n")
        self.proc.stdin.flush()

    def close(self):
        if self.proc.stdin:
            self.proc.stdin.close()
        return self.proc.wait()


def hello(peer, role):
    _, m = peer.read()
    if m.get("type") != "hello" or m.get("protocol") != PROTOCOL or m.get("role") != role:
        fail(f"{peer.name}: expected a {role} hello of {PROTOCOL}, got {m}")
    return m


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("session", help="session folder (tdeploy session start -o ...)")
    parser.add_argument("--tdeploy", default="tdeploy", help="the tdeploy binary")
    parser.add_argument("--approve-all", action="store_true", help="approve every command")
    parser.add_argument("--summary", help="write the run's summary here (JSON)")
    argv = sys.argv[1:]
    rig_args = argv[argv.index("--") + 1 :] if "--" in argv else []
    args = parser.parse_args(argv[: argv.index("--")] if "--" in argv else argv)
    args.rig_args = rig_args

    rig = Peer("rig", [args.tdeploy, "rig", "--stdio", *args.rig_args])
    rig_hello = hello(rig, "rig")
    start_line, start = rig.read()
    controller = Peer("controller", [args.tdeploy, "session", "serve", args.session, "--stdio"])
    ctl_hello = hello(controller, "session")
    if rig_hello["motors"] != ctl_hello["motors"]:
        fail("the rig's motors are not the session's")
    if ctl_hello["phase"] != "awaiting_start":
        fail(
            f"the session is under way ({ctl_hello['phase']}); this client starts a fresh rig at the fold, so it drives new sessions only"
        )
    controller.send(start_line)

    commands, true_gaps, violations = [], [], []
    outcome, words = 2, "the controller stopped talking"
    while True:
        line, m = controller.read()
        kind = m["type"]
        if kind == "command":
            if not m["cleared"]:
                ok = args.approve_all
                if not ok:
                    answer = input(f"approve command {m['step']} {m['payout_change_m']}? [y/N] ")
                    ok = answer.strip().lower() in ("y", "yes")
                if ok:
                    controller.send(json.dumps({"type": "approve", "step": m["step"]}))
                else:
                    controller.send(
                        json.dumps({"type": "reject", "step": m["step"], "reason": "rejected at the rig client"})
                    )
                continue
            commands.append(m["payout_change_m"])
            rig.send(line)
            while True:
                reply_line, reply = rig.read()
                if reply["type"] == "truth":
                    true_gaps.append(reply["true_gaps_m"])
                    violations.extend(reply["violations"])
                    for v in reply["violations"]:
                        print(f"truth, step {reply['step']}: {v}", file=sys.stderr)
                elif reply["type"] == "measurements":
                    controller.send(reply_line)
                    break
                else:
                    fail(f"rig: {reply}")
            largest = max(true_gaps[-1]) * 1e3
            print(f"command {m['step']}: true largest gap {largest:.1f} mm")
        elif kind == "read_again":
            # Readings the operator discarded: read the sensors again.
            rig.send(line)
            reply_line, reply = rig.read()
            if reply["type"] != "measurements":
                fail(f"rig: {reply}")
            controller.send(reply_line)
        elif kind == "stopped":
            outcome, words = 1, f"stopped after step {m['step']}: {m['reason']}"
            break
        elif kind == "ended":
            outcome = 0 if m["status"] == "connected" else 1
            words = m["words"]
            break
        elif kind == "error":
            outcome, words = 2, f"refused ({m['field']}): {m['message']}"
            break
        else:
            fail(f"controller: unexpected {m}")
    controller.close()
    rig.close()
    if outcome == 0 and violations:
        # The controller cannot see the truth; the simulator can. A run
        # that broke a limit is no success, whatever the controller says.
        outcome = 1
        words = f"connected as measured, but {len(violations)} truth limits broken"
    print(f"session: {words}; {len(commands)} commands; truth limits broken: {len(violations)}")
    if args.summary:
        with open(args.summary, "w") as f:
            json.dump(
                {"outcome": words, "commands_m": commands, "true_gaps_m": true_gaps, "violations": violations},
                f,
            )
    sys.exit(outcome)


if __name__ == "__main__":
    main()

"""Cancels a real background render the way a user does in a terminal: Ctrl-C (SIGINT), which
`blender -b` turns into its break flag, the one RenderEngine.test_break() reads.

    python3 cancel_driver.py DELAY_S -- BLENDER ARGS...

Starts Blender, waits for UNBOUND_RENDER_STARTED (cancel_render.py), waits DELAY_S more, sends
SIGINT once, and prints `UNBOUND_CANCEL {json}` with the latency from the signal to the render
operator's return, and what Blender printed."""
import json
import os
import signal
import subprocess
import sys
import threading
import time

delay = float(sys.argv[1])
cmd = sys.argv[sys.argv.index("--") + 1:]
proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, bufsize=1)
lines, sent = [], {}


def cancel_later():
    time.sleep(delay)
    sent["t"] = time.time()
    proc.send_signal(signal.SIGINT)


for line in proc.stdout:
    lines.append(line.rstrip("\n"))
    if line.startswith("UNBOUND_RENDER_STARTED") and not sent:
        sent["pending"] = True
        threading.Thread(target=cancel_later, daemon=True).start()
    if line.startswith("UNBOUND_RENDER_RETURNED "):
        result = json.loads(line[len("UNBOUND_RENDER_RETURNED "):])
        sent.setdefault("t", None)
        result["latency"] = result["t"] - sent["t"] if sent["t"] else None
        print("UNBOUND_CANCEL " + json.dumps(result), flush=True)
rc = proc.wait()
print("\n".join(lines[-40:]))
print("UNBOUND_CANCEL_RC %d" % rc, flush=True)
os._exit(0)

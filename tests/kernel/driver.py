"""driver.py - tests/kernel_spec.lua's hands on the Jupyter side.

    driver.py notebook CELLS OUT.ipynb   a notebook of the cells in CELLS (separated
                                         by lines "-- %%"), run by nbclient
    driver.py read NB.ipynb              a notebook's cells and outputs
    driver.py session                    jupyter_client by hand: an interrupt during
                                         a long simulate, completion, inspection,
                                         a restart

Each prints what it saw as a Lua table (the spec loads it and checks it:
the checks live in the spec, beside what they compare with).  The kernel
spec "nzlua" must be where Jupyter looks (JUPYTER_PATH).  Every wait is
bounded.
"""
import os
import sys
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "tools"))


def lua(v):
    """A Python value as a Lua constructor."""
    if v is None:
        return "nil"
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (int, float)):
        return repr(v)
    if isinstance(v, str):
        out = []
        for b in v.encode("utf-8"):
            c = chr(b)
            out.append(c if 32 <= b < 127 and c not in '\\"' else "\\%03d" % b)
        return '"' + "".join(out) + '"'
    if isinstance(v, (list, tuple)):
        return "{" + ", ".join(lua(x) for x in v) + "}"
    if isinstance(v, dict):
        return "{" + ", ".join("[%s] = %s" % (lua(k), lua(x)) for k, x in v.items()) + "}"
    raise TypeError(type(v))


def output_of(o):
    """A cell's output as the spec reads it."""
    kind = o["output_type"]
    out = {"type": kind}
    if kind == "stream":
        out["name"], out["text"] = o["name"], o["text"]
    elif kind in ("display_data", "execute_result"):
        out["data"] = {k: "".join(v) if isinstance(v, list) else v for k, v in o["data"].items()}
    elif kind == "error":
        out["ename"], out["evalue"], out["traceback"] = o["ename"], o["evalue"], "\n".join(o["traceback"])
    return out


def notebook(cells_file, out):
    import nbformat
    from nbformat.v4 import new_notebook, new_code_cell
    import notebook as nbtool
    text = open(cells_file).read()
    cells = [c.strip("\n") for c in text.split("\n-- %%\n")]
    nb = new_notebook(cells=[new_code_cell(c) for c in cells],
                      metadata={"kernelspec": {"name": "nzlua", "display_name": "nzlua", "language": "lua"}})
    src = out + ".in.ipynb"
    nbformat.write(nb, src)
    t0 = time.time()
    nbtool.execute(src, out, timeout=120)
    read(out, time.time() - t0)


def read(path, seconds=0):
    """A notebook's cells and their outputs, as the spec reads them."""
    import nbformat
    done = nbformat.read(path, as_version=4)
    print("return " + lua({"seconds": float(seconds), "cells": [
        {"type": c.cell_type, "source": c.source, "count": c.get("execution_count"),
         "outputs": [output_of(o) for o in c.get("outputs", [])]}
        for c in done.cells]}))


def session():
    import jupyter_client
    km = jupyter_client.KernelManager(kernel_name="nzlua")
    km.start_kernel()
    kc = km.client()
    kc.start_channels()
    kc.wait_for_ready(timeout=60)
    result = {}

    def reply_to(msg_id, timeout=30):
        """The shell reply to msg_id.  Others are passed over: under load
        wait_for_ready sends kernel_info_request again after a second
        without an answer, so a second kernel_info_reply may wait in the
        channel, and the next request's first reply would be that one (or,
        one later, the previous cell's 'ok')."""
        t0 = time.time()
        while True:
            m = kc.get_shell_msg(timeout=max(0.1, timeout - (time.time() - t0)))
            if m["parent_header"].get("msg_id") == msg_id:
                return m["content"]

    def run(code, interrupt_when=None, limit=120):
        """Execute; collect the cell's outputs; interrupt once interrupt_when(outputs) holds."""
        msg_id = kc.execute(code)
        outs, sent, t0 = [], None, time.time()
        while time.time() - t0 < limit:
            if interrupt_when and sent is None and interrupt_when(outs):
                km.interrupt_kernel()
                sent = time.time() - t0
            try:
                m = kc.get_iopub_msg(timeout=0.2)
            except Exception:
                continue
            if m["parent_header"].get("msg_id") != msg_id:
                continue
            t, c = m["msg_type"], m["content"]
            if t == "status" and c["execution_state"] == "idle":
                break
            if t == "stream":
                outs.append({"type": t, "name": c["name"], "text": c["text"]})
            elif t in ("execute_result", "display_data"):
                outs.append({"type": t, "data": c["data"]})
            elif t == "error":
                outs.append({"type": t, "ename": c["ename"], "evalue": c["evalue"], "traceback": "\n".join(c["traceback"])})
        reply = reply_to(msg_id)
        return {"status": reply["status"], "ename": reply.get("ename"), "outputs": outs,
                "interrupted_after": sent, "seconds": time.time() - t0}

    run("""pend = nz.system{ name = "pendulum", coords = { "th" }, params = { m = 2.0, l = 1.3, g = 9.81 },
  T = function(t, q, qd, p) return 0.5 * p.m * p.l^2 * qd[1]^2 end,
  V = function(t, q, p) return -p.m * p.g * p.l * nz.cos(q[1]) end }""")
    # a run of about 1e8 steps, stopped once its progress bar has shown; an
    # output point every 100 time units (about 2000 steps), so that the part
    # kept holds points beyond the start however soon the stop comes
    def progress_shown(outs):
        return any(o["type"] == "stream" and o["name"] == "stderr" and "%" in o["text"] for o in outs)
    result["interrupt"] = run("tr = pend:simulate{ q0 = { 1 }, qd0 = { 0 }, t1 = 1e7, dt = 100, rtol = 1e-13 }",
                              interrupt_when=progress_shown)
    result["after"] = run("print(nz.last.status, #nz.last.t, nz.last.t[#nz.last.t] < 1e7, rawequal(tr, nz.last))\n6 * 7")
    result["complete"] = kc.complete("x = nz.si", 9, reply=True, timeout=30)["content"]
    result["complete_method"] = kc.complete("pend:acc", 8, reply=True, timeout=30)["content"]
    result["inspect"] = kc.inspect("y = nz.sin(1)", 9, reply=True, timeout=30)["content"]
    result["inspect_missing"] = kc.inspect("nz.no_such_thing", 10, reply=True, timeout=30)["content"]
    result["help_cell"] = run("nz.sin?")
    result["complete_cell"] = reply_to(kc.is_complete("for i = 1, 3 do"))
    result["exit"] = run("os.exit(3)")
    result["after_exit"] = run("print(pend)\n1 + 1")
    km.restart_kernel(now=True)
    kc.wait_for_ready(timeout=60)
    result["restarted"] = run("print(pend)\n1 + 1")
    kc.stop_channels()
    km.shutdown_kernel(now=True)
    print("return " + lua(result))


def pixels(png):
    """How many colours a screenshot has, how many pixels are within 40 of
    #9400D3 (the first series' colour, the first body's), and how many
    shades of that purple there are: a PNG read with zlib alone
    (8-bit RGB or RGBA, not interlaced, as Chromium writes them)."""
    import struct
    import zlib
    data = open(png, "rb").read()
    assert data[:8] == b"\x89PNG\r\n\x1a\n", "not a PNG"
    pos, idat, width = 8, b"", 0
    while pos < len(data):
        n, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + n]
        if kind == b"IHDR":
            width, height, depth, colour, _, _, interlace = struct.unpack(">IIBBBBB", body)
            assert depth == 8 and colour in (2, 6) and interlace == 0, "an unusual PNG"
            bpp = 3 if colour == 2 else 4
        elif kind == b"IDAT":
            idat += body
        pos += 12 + n
    raw, stride = zlib.decompress(idat), width * bpp
    prev, colours, purple, shades, i = bytearray(stride), set(), 0, set(), 0
    for _ in range(height):
        f, line = raw[i], bytearray(raw[i + 1:i + 1 + stride])
        i += 1 + stride
        for x in range(stride):     # undo the filter (PNG spec, 9.2)
            a = line[x - bpp] if x >= bpp else 0
            b, c = prev[x], prev[x - bpp] if x >= bpp else 0
            if f == 1:
                line[x] = (line[x] + a) & 255
            elif f == 2:
                line[x] = (line[x] + b) & 255
            elif f == 3:
                line[x] = (line[x] + (a + b) // 2) & 255
            elif f == 4:
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                line[x] = (line[x] + (a if pa <= pb and pa <= pc else b if pb <= pc else c)) & 255
        for x in range(0, stride, bpp):
            r, g, bl = line[x], line[x + 1], line[x + 2]
            colours.add((r, g, bl))
            if abs(r - 148) + abs(g - 0) + abs(bl - 211) < 40:
                purple += 1
            # #9400D3 lit and shaded: red and blue well above green, blue the larger
            if r > g + 60 and bl > g + 60 and bl >= r:
                shades.add((r, g, bl))
        prev = line
    print("return " + lua({"colours": len(colours), "purple": purple, "purple_shades": len(shades), "width": width,
                           "height": height}))


if __name__ == "__main__":
    {"notebook": notebook, "read": read, "session": session, "pixels": pixels}[sys.argv[1]](*sys.argv[2:])

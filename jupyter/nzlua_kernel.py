"""nzlua_kernel.py - the Jupyter kernel of nzlua: a thin ipykernel wrapper
kernel over `nzlua --kernel-io`.

ipykernel's Kernel base class speaks the Jupyter messaging protocol (ZeroMQ
sockets, signatures, heartbeat, the control channel, restart and shutdown);
this file only turns its requests into frames for nzlua and nzlua's frames
into its replies and IOPub messages (docs/kernel.md has the frames).  The
session itself (cells run as chunks of one Lua state, the display layer,
completion, help, Ctrl-C) is nzlua's, the same as at the terminal prompt.

Interrupt: the notebook's stop button sends SIGINT to this process, which
ipykernel turns into KeyboardInterrupt while a request runs; it is passed
on to nzlua as one SIGINT, which is Ctrl-C at the prompt (a simulate stops
and keeps its partial trajectory in nz.last; the session goes on).  nzlua
runs in a process group of its own, so that a signal sent to the kernel's
group reaches it only through here, once.  A second interrupt during the
same cell is a second Ctrl-C: it ends nzlua (the way out of a loop that
does not stop); the kernel then starts a new nzlua and says so.

Installed by `nzlua --install-kernel` (or `make install`, `make kernel`),
which writes this file beside kernel.json.
"""
import base64
import os
import re
import select
import signal
import subprocess
import sys

from ipykernel.kernelbase import Kernel

# The types of image that travel base64-encoded in a Jupyter message.
BINARY = {"image/gif", "image/png"}


class NzluaDied(Exception):
    """nzlua ended while the kernel waited for a frame."""


class Nzlua:
    """An `nzlua --kernel-io` process and the frames to and from it."""

    def __init__(self, program):
        self.program = program
        self.proc = subprocess.Popen(
            [program, "--kernel-io"], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
            stderr=subprocess.PIPE, start_new_session=True)
        self.out = self.proc.stdout.fileno()
        self.err = self.proc.stderr.fileno()
        self.buf = b""
        self.on_wait = None     # called while waiting for nzlua's bytes
        kind, fields = self.read_frame(lambda name, text: None)
        if kind != "hello":
            raise NzluaDied("nzlua --kernel-io did not say hello (got %r)" % kind)
        self.version = fields.get("version", b"").decode()
        self.lua = fields.get("lua", b"").decode()

    def send(self, kind, **fields):
        parts = [("NZ %s %d\n" % (kind, len(fields))).encode()]
        for name, value in fields.items():
            data = value if isinstance(value, bytes) else str(value).encode()
            parts += [("%s %d\n" % (name, len(data))).encode(), data, b"\n"]
        try:
            self.proc.stdin.write(b"".join(parts))
            self.proc.stdin.flush()
        except OSError:           # it ended between two requests
            raise NzluaDied(self.exit_reason())

    def _fill(self, on_stderr):
        """Read what is there: frames' bytes into the buffer, and what child
        processes wrote to stderr (and to stdout, which nzlua points at
        stderr) straight to on_stderr."""
        if self.on_wait:
            self.on_wait()
        ready, _, _ = select.select([self.out, self.err], [], [], 0.2)
        if self.err in ready:
            data = os.read(self.err, 65536)
            if data:
                on_stderr("stderr", data.decode("utf-8", "replace"))
        if self.out in ready:
            data = os.read(self.out, 65536)
            if not data:
                raise NzluaDied(self.exit_reason())
            self.buf += data

    def _take_line(self, on_stderr):
        while b"\n" not in self.buf:
            self._fill(on_stderr)
        line, self.buf = self.buf.split(b"\n", 1)
        return line.decode()

    def _take(self, n, on_stderr):
        while len(self.buf) < n + 1:
            self._fill(on_stderr)
        data, self.buf = self.buf[:n], self.buf[n + 1:]
        return data

    def read_frame(self, on_stderr):
        magic, kind, count = self._take_line(on_stderr).split(" ")
        if magic != "NZ":
            raise NzluaDied("nzlua sent something that is not a frame: %r" % magic)
        fields = {}
        for _ in range(int(count)):
            name, length = self._take_line(on_stderr).rsplit(" ", 1)
            fields[name] = self._take(int(length), on_stderr)
        return kind, fields

    def interrupt(self):
        if self.proc.poll() is None:
            os.kill(self.proc.pid, signal.SIGINT)

    def exit_reason(self):
        try:
            code = self.proc.wait(timeout=5)
        except subprocess.TimeoutExpired:
            return "nzlua stopped answering"
        if code < 0 and -code == signal.SIGINT:
            return "nzlua ended at a second interrupt (the first one had not stopped the computation yet)"
        if code < 0:
            return "nzlua ended by signal %d" % -code
        return "nzlua exited with status %d" % code

    def close(self):
        if self.proc.poll() is None:
            try:
                self.send("shutdown")
                self.proc.wait(timeout=5)
            except (OSError, subprocess.TimeoutExpired):
                self.proc.kill()
                self.proc.wait()


class NzluaKernel(Kernel):
    implementation = "nzlua"
    implementation_version = "1"
    language = "lua"
    language_version = "5.4"
    language_info = {
        "name": "lua", "mimetype": "text/x-lua", "file_extension": ".lua",
        "codemirror_mode": "lua", "pygments_lexer": "lua",
    }
    help_links = []
    program = os.environ.get("NZLUA_KERNEL_PROGRAM", "nzlua")

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.nzlua = Nzlua(self.program)
        self.banner = "nzlua %s (%s): analytical mechanics with Taylor jets" % (self.nzlua.version, self.nzlua.lua)

    # -- output -----------------------------------------------------------

    def _stream(self, name, text):
        # a warning says where as an error does: "In [3], line 2:", not "In [3]:2:"
        text = re.sub(r"In \[(\d+)\]:(\d+):", r"In [\1], line \2:", text)
        self.send_response(self.iopub_socket, "stream", {"name": name, "text": text})

    def _bundle(self, fields):
        data = {}
        for mime, value in fields.items():
            if mime in BINARY:
                data[mime] = base64.b64encode(value).decode("ascii")
            else:
                data[mime] = value.decode("utf-8", "replace")
        return data

    # -- requests ---------------------------------------------------------

    def _restart_nzlua(self, why):
        self._stream("stderr", "%s: a new nzlua session started (the variables of the old one are gone)\n" % why)
        self.nzlua.close()
        self.nzlua = Nzlua(self.program)

    def do_execute(self, code, silent, store_history=True, user_expressions=None, allow_stdin=False):
        # The stop button's SIGINT only counts here (no KeyboardInterrupt
        # that could cut a read in two); each one is passed on to nzlua
        # once the cell runs (before that, nzlua ignores SIGINT).
        state = {"started": False, "asked": 0, "sent": 0}

        def on_sigint(signum, frame):
            state["asked"] += 1

        def forward():
            while state["started"] and state["sent"] < state["asked"]:
                state["sent"] += 1
                self.nzlua.interrupt()

        previous = signal.signal(signal.SIGINT, on_sigint)
        self.nzlua.on_wait = forward
        try:
            return self._execute(code, silent, state)
        finally:
            self.nzlua.on_wait = None
            signal.signal(signal.SIGINT, previous)

    def _execute(self, code, silent, state):
        on_stderr = (lambda name, text: None) if silent else self._stream
        while True:
            try:
                if not state.get("requested"):
                    state["requested"] = True
                    self.nzlua.send("execute", cell=self.execution_count, code=code.encode())
                kind, fields = self.nzlua.read_frame(on_stderr)
            except NzluaDied as e:
                self._restart_nzlua(str(e))
                return self._error("died", str(e), [str(e)])
            if kind == "started":
                state["started"] = True
            elif kind == "stream":
                if not silent:
                    self._stream(fields["name"].decode(), fields["text"].decode("utf-8", "replace"))
            elif kind in ("display", "result"):
                if silent:
                    continue
                if kind == "result":
                    self.send_response(self.iopub_socket, "execute_result", {
                        "execution_count": self.execution_count, "data": self._bundle(fields), "metadata": {}})
                else:
                    self.send_response(self.iopub_socket, "display_data", {"data": self._bundle(fields), "metadata": {}})
            elif kind == "done":
                status = fields["status"].decode()
                if status == "ok":
                    return {"status": "ok", "execution_count": self.execution_count,
                            "payload": [], "user_expressions": {}}
                traceback = fields.get("traceback", b"").decode("utf-8", "replace").split("\n")
                return self._error(fields.get("ename", b"error").decode(), fields.get("evalue", b"").decode(),
                                   traceback, silent)

    def _error(self, ename, evalue, traceback, silent=False):
        content = {"ename": ename, "evalue": evalue, "traceback": traceback}
        if not silent:
            self.send_response(self.iopub_socket, "error", content)
        content.update({"status": "error", "execution_count": self.execution_count})
        return content

    def _ask(self, kind, **fields):
        """A request that is answered at once (completion, help); {} when
        nzlua has ended (the next cell starts a new one)."""
        try:
            self.nzlua.send(kind, **fields)
            while True:
                reply, data = self.nzlua.read_frame(lambda name, text: None)
                if reply not in ("stream", "display"):
                    return data
        except NzluaDied:
            return {}

    def do_complete(self, code, cursor_pos):
        # Jupyter counts characters, nzlua bytes
        at = len(code[:cursor_pos].encode())
        data = self._ask("complete", code=code.encode(), cursor=at)
        matches = data.get("matches", b"").decode()
        start = len(code.encode()[:int(data.get("start", at))].decode("utf-8", "replace"))
        return {"status": "ok", "matches": matches.split("\n") if matches else [],
                "cursor_start": start, "cursor_end": cursor_pos, "metadata": {}}

    def do_inspect(self, code, cursor_pos, detail_level=0, omit_sections=()):
        at = len(code[:cursor_pos].encode())
        data = self._ask("inspect", code=code.encode(), cursor=at)
        found = data.get("found") == b"true"
        return {"status": "ok", "found": found, "metadata": {},
                "data": {"text/plain": data["text/plain"].decode()} if found else {}}

    def do_is_complete(self, code):
        data = self._ask("is_complete", code=code.encode())
        status = data.get("status", b"unknown").decode()
        return {"status": status, "indent": "  " if status == "incomplete" else ""}

    def do_shutdown(self, restart):
        self.nzlua.close()
        return {"status": "ok", "restart": restart}


def main():
    args = sys.argv[1:]
    if "--nzlua" in args:
        i = args.index("--nzlua")
        NzluaKernel.program = args[i + 1]
        del args[i:i + 2]
    sys.argv[1:] = args
    from ipykernel.kernelapp import IPKernelApp
    IPKernelApp.launch_instance(kernel_class=NzluaKernel)


if __name__ == "__main__":
    main()

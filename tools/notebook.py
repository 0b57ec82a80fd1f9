"""notebook.py - run a notebook on the nzlua kernel, render it, look at it.

    notebook.py execute IN.ipynb OUT.ipynb   run every cell (nbclient, no browser)
    notebook.py html IN.ipynb OUT.html       render with nbconvert, MathJax from
                                             Debian's libjs-mathjax (no network)
    notebook.py screenshot IN.html OUT.png [W H]  headless Chromium's picture of the page
    notebook.py dom IN.html                  the page after its scripts ran (MathJax)

The kernel spec "nzlua" must be where Jupyter looks (JUPYTER_PATH; `nzlua
--install-kernel --prefix DIR` puts it in DIR/share/jupyter).  Used by
`make notebook-screenshot` and tests/kernel_spec.lua.  Run with Debian's
/usr/bin/python3 (python3-nbclient, python3-nbconvert).
"""
import os
import subprocess
import sys
import tempfile

MATHJAX = "/usr/share/javascript/mathjax/MathJax.js"
CHROMIUM = os.environ.get("CHROMIUM", "/usr/bin/chromium")
# Headless, offline, nothing kept between runs (a fresh profile each time):
# without the background-networking flags Chromium keeps trying hosts that a
# closed network refuses.  WebGL (tr:animate{ view = "3d" }) on the CPU,
# with SwiftShader: there is no GPU, and Chromium no longer falls back to it
# by itself.
CHROMIUM_FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
                  "--disable-component-update", "--disable-sync", "--no-first-run", "--disable-quic",
                  "--hide-scrollbars", "--allow-file-access-from-files", "--use-angle=swiftshader",
                  "--enable-unsafe-swiftshader"]


def execute(src, dst, timeout=300):
    import nbformat
    from nbclient import NotebookClient
    nb = nbformat.read(src, as_version=4)
    NotebookClient(nb, kernel_name="nzlua", timeout=timeout, allow_errors=True,
                   resources={"metadata": {"path": os.path.dirname(os.path.abspath(src))}}).execute()
    nbformat.write(nb, dst)


def html(src, dst):
    import nbformat
    from nbconvert import HTMLExporter
    nb = nbformat.read(src, as_version=4)
    # nbconvert 6.5 passes an SVG through lxml's HTML cleaner, which strips
    # its attributes (viewBox, transform: a blank picture; nbconvert issue
    # 1894): the notebook's SVG is nzlua's own gnuplot output, kept as it is
    exporter = HTMLExporter(filters={"clean_html": lambda s: s})
    # MathJax from the Debian package, by a file URL: the page needs no network
    exporter.mathjax_url = "file://" + MATHJAX + "?config=TeX-AMS_CHTML-full"
    body, _ = exporter.from_notebook_node(nb)
    with open(dst, "w") as f:
        f.write(body)


def chromium(page, *args):
    with tempfile.TemporaryDirectory() as profile:
        cmd = [CHROMIUM] + CHROMIUM_FLAGS + ["--user-data-dir=" + profile, "--virtual-time-budget=15000"] + list(args)
        cmd.append("file://" + os.path.abspath(page))
        return subprocess.run(cmd, capture_output=True, timeout=120)


def screenshot(page, png, width=1000, height=2400):
    r = chromium(page, "--screenshot=" + os.path.abspath(png), "--window-size=%s,%s" % (width, height))
    if not os.path.exists(png):
        sys.exit("chromium made no screenshot: %s" % r.stderr.decode(errors="replace")[-2000:])


def dom(page):
    r = chromium(page, "--dump-dom")
    sys.stdout.write(r.stdout.decode("utf-8", "replace"))


def main():
    cmd, args = sys.argv[1], sys.argv[2:]
    {"execute": execute, "html": html, "screenshot": screenshot, "dom": dom}[cmd](*args)


if __name__ == "__main__":
    main()

-- kernel_spec.lua - nzlua as a Jupyter kernel, driven as Jupyter drives it:
-- the kernel spec installed by `nzlua --install-kernel`, a notebook of the
-- tutorial's first sections (and cells of our own) run by nbclient with no
-- browser, jupyter_client by hand for the stop button, Tab, Shift-Tab and
-- a restart (tests/kernel/driver.py prints what it saw as a Lua table),
-- and a real browser: the example notebook rendered by nbconvert and
-- photographed by headless Chromium (#slow).  Debian's /usr/bin/python3 has
-- the packages (python3-ipykernel, python3-nbclient, ...); `make deps`
-- installs them.
local h = require "tests.helpers"

local PYTHON = "/usr/bin/python3"
local dir = os.tmpname()
os.remove(dir)
assert(os.execute("mkdir -p " .. dir))
local jupyter_path = dir .. "/share/jupyter"
local env = ("JUPYTER_PATH=%s JUPYTER_DATA_DIR=%s/data JUPYTER_RUNTIME_DIR=%s/runtime IPYTHONDIR=%s/ipython "
  .. "PYDEVD_DISABLE_FILE_VALIDATION=1 "):format(jupyter_path, dir, dir, dir)

-- What is missing to run these tests, or nil.
local function missing()
  local code = h.run(PYTHON .. " -c 'import ipykernel, jupyter_client, nbclient, nbconvert, nbformat, zmq'")
  if code ~= 0 then
    return "Debian's python3-ipykernel, jupyter-client, python3-nbclient, python3-nbconvert are not installed (make deps)"
  end
end

-- Run the driver; the Lua table it printed.
local function drive(args)
  local code, out, err = h.run(env .. PYTHON .. " tests/kernel/driver.py " .. args)
  assert(code == 0, ("driver.py %s failed (%d):\n%s\n%s"):format(args, code, out, err))
  local chunk = assert(load(out, "=driver.py " .. args), "driver.py printed no Lua table:\n" .. out .. err)
  return chunk()
end

-- The outputs of a cell of a given type (and stream name).
local function outputs(cell, kind, name)
  local list = {}
  for _, o in ipairs(cell.outputs) do
    if o.type == kind and (not name or o.name == name) then list[#list + 1] = o end
  end
  return list
end

local function stream(cell, name)
  local parts = {}
  for _, o in ipairs(outputs(cell, "stream", name)) do parts[#parts + 1] = o.text end
  return table.concat(parts)
end

local function data(cell, mime)
  for _, o in ipairs(cell.outputs) do
    if o.data and o.data[mime] then return o.data[mime], o.type end
  end
end

-- The numbers in the cells of an HTML table's body row that starts with `first`.
local function html_row(html, first)
  local row = html:match("<tr><td[^>]*>" .. first:gsub("%p", "%%%0") .. "</td>(.-)</tr>")
  local cells = {}
  for cell in (row or ""):gmatch("<td[^>]*>(.-)</td>") do cells[#cells + 1] = cell end
  return cells
end

-- The frames nzlua --kernel-io wrote (docs/kernel.md), as {kind, fields}.
local function frames(out)
  local list, at = {}, 1
  while at <= #out do
    local kind, n, stop = out:match("^NZ (%S+) (%d+)\n()", at)
    assert(kind, "not a frame at byte " .. at .. ": " .. out:sub(at, at + 80))
    at = stop
    local fields = {}
    for _ = 1, tonumber(n) do
      local name, len, start = out:match("^(%S+) (%d+)\n()", at)
      fields[name] = out:sub(start, start + tonumber(len) - 1)
      at = start + tonumber(len) + 1
    end
    list[#list + 1] = { kind = kind, fields = fields }
  end
  return list
end

-- A request frame.
local function frame(kind, ...)
  local parts, fields = { "" }, { ... }
  for i = 1, #fields, 2 do parts[#parts + 1] = ("%s %d\n%s\n"):format(fields[i], #fields[i + 1], fields[i + 1]) end
  return ("NZ %s %d\n"):format(kind, #fields // 2) .. table.concat(parts)
end

describe("nzlua --kernel-io: a malformed request gets a protocol error and the session goes on", function()
  -- each case: the request's bytes, then what the error says
  local cases = {
    { "a cell number 1e999", frame("execute", "cell", "1e999", "code", "1+1"), "field 'cell' must be a whole number" },
    { "a cell number -99999999999999999999", frame("execute", "cell", "-99999999999999999999", "code", "1"),
      "got '-99999999999999999999'" },
    { "a cursor 1e300", frame("complete", "code", "nz.si", "cursor", "1e300"), "field 'cursor' must be a whole number from 0 to 5" },
    { "a cursor -99999999999999999999", frame("inspect", "code", "nz.si", "cursor", "-99999999999999999999"),
      "field 'cursor' must be a whole number" },
    { "a cursor abc", frame("complete", "code", "nz.si", "cursor", "abc"), "got 'abc'" },
    { "a negative field length", "NZ execute 1\ncode -5\nxxxxx\n", "its length is not a count of bytes" },
    { "a huge field length", "NZ execute 1\ncode 99999999999999999999\n", "its length 99999999999999999999 is more "
      .. "than the cap (16777216 bytes a field, 67108864 bytes a frame)" },
    { "a field just over the cap", "NZ execute 1\ncode 16777217\n", "is more than the cap" },
    { "fields over the cap of a frame together", "NZ execute 5\na 16777216\n" .. ("x"):rep(16777216) .. "\nb 16777216\n"
      .. ("x"):rep(16777216) .. "\nc 16777216\n" .. ("x"):rep(16777216) .. "\nd 16777216\n" .. ("x"):rep(16777216)
      .. "\ne 1\n", "is more than the cap" },
    { "a field count 1e3", "NZ execute 1e3\n", "a frame must start with 'NZ <kind> <nfields>'" },
    { "a field count of -1", "NZ execute -1\n", "nfields from 0 to 64" },
  }
  for _, c in ipairs(cases) do
    it(c[1], function()
      local input = c[2] .. frame("execute", "cell", "2", "code", "6 * 7")
      local code, out, err = h.run(h.nzlua .. " --kernel-io", input)
      assert.equal(0, code, err)
      local list = frames(out)
      assert.equal("hello", list[1].kind)
      local bad = list[2]
      assert.equal("done", bad.kind)
      assert.equal("error", bad.fields.status)
      assert.equal("protocol", bad.fields.ename)
      assert.truthy(bad.fields.evalue:find(c[3], 1, true), bad.fields.evalue)
      -- and the next request is answered as ever
      local kinds = {}
      for i = 3, #list do kinds[#kinds + 1] = list[i].kind end
      assert.equal("started result done", table.concat(kinds, " "))
      assert.equal("42", list[4].fields["text/plain"])
      assert.equal("ok", list[5].fields.status)
    end)
  end
end)

describe("the Jupyter kernel", function()
  local why = missing()
  if why then
    it("needs Jupyter's Debian packages", function() pending(why) end)
    return
  end

  it("is registered by nzlua --install-kernel: jupyter kernelspec list shows 'nzlua'", function()
    local code, out, err = h.run(h.nzlua .. " --install-kernel --prefix " .. dir)
    assert(code == 0, out .. err)
    assert(out:find("kernel spec 'nzlua' installed", 1, true), out)
    local spec = assert(h.slurp(jupyter_path .. "/kernels/nzlua/kernel.json"))
    assert(spec:find('"{resource_dir}/nzlua_kernel.py"', 1, true), spec)
    -- three.js for the 3-D view, served from the spec's folder (Debian's copy)
    local three = io.open("/usr/share/javascript/three/build/three.min.js")
    if three then
      three:close()
      local served = assert(io.open(jupyter_path .. "/kernels/nzlua/three.min.js"), "three.js is not in the kernel spec")
      assert(served:read(2000):find("THREE", 1, true), "the kernel spec's three.min.js is not three.js")
      served:close()
    end
    code, out, err = h.run(env .. PYTHON .. " -m jupyter_client.kernelspecapp list")
    assert(code == 0, out .. err)
    assert(out:match("\n%s*nzlua%s+" .. jupyter_path:gsub("%p", "%%%0") .. "/kernels/nzlua"), out)
    -- a wrong option is refused with what to write
    code, out, err = h.run(h.nzlua .. " --install-kernel --prefx /tmp")
    assert(code ~= 0 and err:find("unknown option '--prefx' (--user, --prefix DIR", 1, true), err)
  end)

  describe("running a notebook (nbclient)", function()
    -- the tutorial's first sections (1 to 5) as cells, then our own
    local tutorial = assert(h.slurp("docs/tutorial.md"))
    local cells = {}
    for body in tutorial:sub(1, assert(tutorial:find("\n## 6%."))):gmatch("```lua\n(.-)```") do cells[#cells + 1] = body end
    local n_tutorial = #cells
    local ours = {
      pendulum = [[
pend = nz.system{ name = "pendulum", coords = { "th" }, params = { m = 2.0, l = 1.3, g = 9.81 },
  T = function(t, q, qd, p) return 0.5 * p.m * p.l^2 * qd[1]^2 end,
  V = function(t, q, p) return -p.m * p.g * p.l * nz.cos(q[1]) end }
pend:show{}]],
      last_value = "a = 20\na + 22",
      streams = 'print("one", 2)\nio.write("three\\n")\nio.stderr:write("four\\n")\nos.execute("echo five")',
      lin = "lin = pend:linearize{ q = { 0 } }\nprint(lin)",
      residuals = "tr:residuals()",
      animation = [[
bob = nz.system{ name = "bob", coords = { "th" },
  bodies = { gravity = { 0, -9.81, 0 }, { mass = 1, pos = function(t, q) return { sin(q[1]), -cos(q[1]), 0 } end } } }
swing = bob:simulate{ q0 = { 1 }, qd0 = { 0 }, t1 = 2, dt = 0.05 }
swing:animate{ frames = 5 }]],
      define = "function bad(v)\n  return v.x.y\nend",
      error_here = "x = 1\nlocal y = x + nil",
      error_deep = "z = 1\nbad({})",
      after_error = "x + 1",
    }
    local order = { "pendulum", "last_value", "streams", "lin", "residuals", "animation", "define", "error_here",
      "error_deep", "after_error" }
    local at = {}
    for _, name in ipairs(order) do cells[#cells + 1] = ours[name]; at[name] = #cells end
    local file = dir .. "/cells.lua"
    local f = assert(io.open(file, "w"))
    f:write(table.concat(cells, "\n-- %%\n"))
    f:close()
    local nb
    local function cell(name) return nb.cells[at[name]] end
    setup(function() nb = drive(("notebook %s %s/tutorial.ipynb"):format(file, dir)) end)

    it("runs the tutorial's first sections as cells of one session, each with its number", function()
      assert(#nb.cells == #cells, "cells: " .. #nb.cells)
      for i = 1, n_tutorial do
        local c = nb.cells[i]
        assert(c.count == i, ("cell %d ran as In [%s]"):format(i, tostring(c.count)))
        assert(#outputs(c, "error") == 0, ("tutorial cell %d failed:\n%s\n%s"):format(i, c.source,
          (outputs(c, "error")[1] or {}).traceback))
      end
      -- what the tutorial's output blocks show, printed by its cells (section 1's jet)
      assert(stream(nb.cells[1], "stdout"):find("-0.166667 -1.000000", 1, true), stream(nb.cells[1], "stdout"))
      -- globals persist from cell to cell: section 5 simulates the sleigh of section 2
      assert(stream(nb.cells[5], "stdout"):find("done\t201", 1, true), stream(nb.cells[5], "stdout"))
    end)

    it("shows sys:show{} as LaTeX for MathJax beside its text: the pendulum's m l^2 th'' + m g l sin th = 0", function()
      local c = cell("pendulum")
      local tex, kind = data(c, "text/latex")
      assert(kind == "execute_result", "no text/latex result: " .. tostring(kind))
      -- Lagrange by hand: d/dt(m l^2 th') + m g l sin th = 0, in display math
      local norm = tex:gsub("\\,", ""):gsub("%s", "")
      assert(norm:find("^%$%$\\begin{aligned}"), tex)
      assert(norm:find("l^{2}m\\ddot{\\theta}+glm\\sin\\left(\\theta\\right)&=0", 1, true), tex)
      assert(norm:find("\\end{aligned}%$%$$"), tex)
      local text = data(c, "text/plain")
      assert(text:find("th:  l^2 m th'' + g l m sin(th) = 0", 1, true), text)
    end)

    it("shows a cell's last expression once, as the session shows it", function()
      local c = cell("last_value")
      assert(data(c, "text/plain") == "42", tostring(data(c, "text/plain")))
      assert(#outputs(c, "execute_result") == 1)
      -- tr:residuals() printed its result: shown once (display data), no result after it
      assert(#outputs(cell("residuals"), "execute_result") == 0, "tr:residuals() was shown twice")
    end)

    it("streams print and io.write to stdout and io.stderr and child processes to stderr", function()
      local c = cell("streams")
      assert(stream(c, "stdout") == "one\t2\nthree\n", ("%q"):format(stream(c, "stdout")))
      local err = stream(c, "stderr")
      assert(err:find("four\n", 1, true) and err:find("five\n", 1, true), ("%q"):format(err))
    end)

    it("draws tr:plot{} as an SVG in an <img> with the plot's labels, sized from its characters, and a PNG", function()
      local c = nb.cells[5]    -- tr:plot{ x = "x", y = { "y" }, width = 70, height = 16 }
      local html, kind = data(c, "text/html")
      assert(kind == "display_data" and html, "no HTML in section 5's outputs")
      local svg = h.img_data(html, "image/svg+xml")
      assert(svg and svg:find("<svg", 1, true), "no <img> of an SVG: " .. html:sub(1, 80))
      assert(svg:find('width="560" height="256"', 1, true), "70 x 16 characters are 560 x 256 pixels")
      local png = h.unbase64(assert(data(c, "image/png"), "no PNG"))
      assert(png:sub(1, 8) == "\137PNG\r\n\26\n" and string.unpack(">I4", png, 17) == 560, "no PNG of 560 pixels")
      for _, label in ipairs{ "sleigh", "x", "y" } do     -- title (the system), x and y labels
        assert(svg:find(">" .. label .. "</tspan>", 1, true), "the SVG has no label " .. label)
      end
      assert(data(c, "text/plain"):find("plot 'sleigh'", 1, true))
      assert(not stream(c, "stdout"):find("+-----", 1, true), "the terminal's drawing reached the notebook")
    end)

    it("shows print(lin) and tr:residuals() with their tables as HTML beside the text", function()
      local html = data(cell("lin"), "text/html")
      assert(html, "print(lin) gave no HTML")
      assert(html:find("<th style=\"text-align:right\">frequency (rad/s)</th>", 1, true), html)
      -- the small oscillation's frequency: sqrt(g / l) by hand
      local row = html_row(html, ("0 +- %gi"):format(math.sqrt(9.81 / 1.3)))
      assert(math.abs(tonumber(row[1]) - math.sqrt(9.81 / 1.3)) < 1e-5, html)
      assert(data(cell("lin"), "text/plain"):find("linearization of 'pendulum'", 1, true))
      local res = assert(data(cell("residuals"), "text/html"), "tr:residuals() gave no HTML")
      local _, tables = res:gsub("<table", "")
      assert(tables == 3, "the sleigh's defect has three tables (equations, velocities, its constraint): " .. tables)
      assert(res:find("<th style=\"text-align:left\">constraint</th>", 1, true), res)
    end)

    it("shows tr:animate{} as an inline animated GIF", function()
      local c = cell("animation")
      local gif = assert(data(c, "image/gif"), "no image/gif")
      assert(gif:sub(1, 8) == "R0lGODlh", "not a GIF89a: " .. gif:sub(1, 8))     -- base64 of "GIF89a"
      assert(data(c, "text/html"):find('<img src="data:image/gif;base64,R0lGODlh', 1, true))
      assert(data(c, "text/plain") == "animation of 'bob': 5 frames")
    end)

    it("says an error's place as 'In [n], line m', with the user's frames only", function()
      local e = outputs(cell("error_here"), "error")[1]
      local n = cell("error_here").count
      assert(e and e.evalue:find(("^In %%[%d%%], line 2: attempt to perform arithmetic on a nil value"):format(n)),
        e and e.evalue)
      local deep = outputs(cell("error_deep"), "error")[1]
      local d, m = cell("define").count, cell("error_deep").count
      assert(deep.traceback:find(("In [%d], line 2: attempt to index a nil value (field 'x')"):format(d), 1, true),
        deep.traceback)
      assert(deep.traceback:find(("In [%d], line 2: in main chunk"):format(m), 1, true), deep.traceback)
      for _, tb in ipairs{ e.traceback, deep.traceback } do
        assert(not tb:find("lua/nz/", 1, true) and not tb:find("[C]", 1, true) and not tb:find("/tmp", 1, true), tb)
      end
      -- and the session goes on
      assert(data(cell("after_error"), "text/plain") == "2")
    end)
  end)

  describe("driven by hand (jupyter_client)", function()
    local s
    setup(function() s = drive("session") end)

    it("stops a long simulate at the stop button, keeps its partial trajectory in nz.last, and stays alive", function()
      local r = s.interrupt
      assert(r.interrupted_after, "the run's progress never showed, so it was not interrupted")
      assert(r.status == "error" and r.ename == "interrupted", tostring(r.status) .. " " .. tostring(r.ename))
      local err = ""
      for _, o in ipairs(r.outputs) do if o.type == "stream" then err = err .. o.text end end
      assert(err:find("stopped by Ctrl-C at t = ", 1, true), err)
      assert(r.seconds < r.interrupted_after + 10, ("it went on for %.1f s after the interrupt"):format(r.seconds - r.interrupted_after))
      local a = s.after
      assert(a.status == "ok", tostring(a.status))
      local printed = a.outputs[1].text
      local status, n, short, same = printed:match("^(%S+)\t(%d+)\t(%S+)\t(%S+)\n$")
      assert(status == "interrupted" and tonumber(n) > 1 and short == "true" and same == "true", printed)
      assert(a.outputs[2].data["text/plain"] == "42")
    end)

    it("completes with the session's completer", function()
      local c = s.complete
      assert(c.status == "ok" and c.cursor_start == 4 and c.cursor_end == 9, tostring(c.cursor_start))
      local set = {}
      for _, m in ipairs(c.matches) do set[m] = true end
      assert(set["nz.sin"] and set["nz.sinh"] and set["nz.sign"], table.concat(c.matches, " "))
      local found = false
      for _, m in ipairs(s.complete_method.matches) do found = found or m == "pend:accel" end
      assert(found, table.concat(s.complete_method.matches, " "))
    end)

    it("inspects with help(...): the text the session's help gives", function()
      local _, want = h.run(h.nzlua .. [[ -e 'io.write(help(nz.sin, { quiet = true }))']])
      assert(s.inspect.found == true and s.inspect.data["text/plain"] == want, tostring(s.inspect.data["text/plain"]))
      assert(s.inspect_missing.found == false)
      local help = ""
      for _, o in ipairs(s.help_cell.outputs) do help = help .. (o.text or "") end
      assert(help == want .. "\n", ("nz.sin? printed %q"):format(help))
      assert(s.complete_cell.status == "incomplete")
    end)

    it("starts a new nzlua when the old one ended (os.exit in a cell), and says so", function()
      local r = s.exit
      assert(r.status == "error" and r.ename == "died", tostring(r.status) .. " " .. tostring(r.ename))
      local said = ""
      for _, o in ipairs(r.outputs) do said = said .. (o.text or o.evalue or "") end
      assert(said:find("nzlua exited with status 3", 1, true) and said:find("a new nzlua session started", 1, true), said)
      local a = s.after_exit
      assert(a.status == "ok" and a.outputs[1].text == "nil\n" and a.outputs[2].data["text/plain"] == "2")
    end)

    it("restarts as a new session", function()
      local r = s.restarted
      assert(r.status == "ok" and r.outputs[1].text == "nil\n" and r.outputs[2].data["text/plain"] == "2",
        tostring(r.outputs[1] and r.outputs[1].text))
    end)
  end)

  describe("in a browser #slow", function()
    local chromium = "/usr/bin/chromium"
    it("keeps a plot in a notebook exported by python3 -m nbconvert (HTML, and the PNG LaTeX takes for a PDF)", function()
      if not io.open(chromium) then pending("Debian's chromium is not installed (make deps)") return end
      local cells, nb = dir .. "/export.lua", dir .. "/export.ipynb"
      local f = assert(io.open(cells, "w"))
      f:write([[
bob = nz.system{ name = "bob", coords = { "x" }, T = function(t, q, qd) return 0.5 * qd[1]^2 end,
  V = function(t, q) return 0.5 * q[1]^2 end }
tr = bob:simulate{ q0 = { 1 }, t1 = 10, dt = 0.05 }
tr:plot{ y = { "x" }, title = "exported" }]])
      f:close()
      drive(("notebook %s %s"):format(cells, nb))
      -- what a teacher types: nbconvert as it is, nothing of ours around it
      local code, out, err = h.run(("cd %s && %s -m nbconvert --to html export.ipynb"):format(dir, PYTHON))
      assert(code == 0, out .. err)
      local page = assert(h.slurp(dir .. "/export.html"))
      assert(page:find('<img src="data:image/svg+xml;base64,', 1, true), "the page has no image of the plot")
      local png = dir .. "/export.png"
      code, out, err = h.run(env .. PYTHON .. " tools/notebook.py screenshot " .. dir .. "/export.html " .. png .. " 1000 900")
      assert(code == 0, out .. err)
      -- the plot's curve in its colour (#9400D3, plot.lua's first): inline, nbconvert left a blank box
      local shot = drive("pixels " .. png)
      assert(shot.purple > 100, "the exported page shows no curve: " .. shot.purple .. " purple pixels")
      -- LaTeX (nbconvert's way to a PDF) takes the PNG, written beside the .tex
      code, out, err = h.run(("cd %s && %s -m nbconvert --to latex export.ipynb"):format(dir, PYTHON))
      assert(code == 0, out .. err)
      local tex = assert(h.slurp(dir .. "/export.tex"))
      local image = tex:match("\\adjustimage{[^\n]-}{([^{}\n]+%.png)}")
      assert(image, "the LaTeX includes no PNG")
      local bytes = assert(h.slurp(dir .. "/" .. image), image)
      assert(bytes:sub(1, 8) == "\137PNG\r\n\26\n", image .. " is not a PNG")
    end)

    it("draws tr:animate{ view = '3d' } of the heavy top and the rolling disk with three.js in an exported page", function()
      if not io.open(chromium) then pending("Debian's chromium is not installed (make deps)") return end
      if not io.open("/usr/share/javascript/three/build/three.min.js") then
        pending("Debian's libjs-three is not installed (make kernel)") return
      end
      local cells, nb = dir .. "/scene.lua", dir .. "/scene.ipynb"
      local f = assert(io.open(cells, "w"))
      -- the heavy top and the rolling disk of examples/ (nothing else on the
      -- page is purple: no plot)
      f:write([[
m, lc = 1.5, 0.4
function rot(t, q) return nz.rotations.euler_zxz(q[1], q[2], q[3]) end
top = nz.scene{ name = "heavy symmetric top", coords = { "psi", "theta", "phi" },
  bodies = { { name = "top", mass = m, inertia = { 0.06, 0.06, 0.2 }, rot = rot,
    pos = function(t, q) local R = rot(t, q); return { lc * R[1][3], lc * R[2][3], lc * R[3][3] } end } },
  effects = { nz.effects.gravity{ g = { 0, 0, -9.81 } } } }
spin = top:simulate{ q0 = { 0, 0.5, 0 }, qd0 = { 0, 0, 40 }, t1 = 1, dt = 0.01 }
spin:animate{ view = "3d", frames = 30, width = 50, height = 20 }
-- %%
R, z, x = 0.3, nz.rotations.z, nz.rotations.x
disk = nz.scene{ name = "vertical rolling disk", coords = { "x", "y", "th", "ph" },
  bodies = { { name = "disk", mass = 1.2, inertia = { 0.05, 0.05, 0.08 }, pos = function(t, q) return { q[1], q[2], R } end,
    rot = function(t, q) return nz.rotations.mul(nz.rotations.mul(z(q[3]), x(-math.pi / 2)), z(q[4])) end } },
  effects = { nz.effects.rolling_disk{ x = "x", y = "y", heading = "th", angle = "ph", radius = R } } }
roll = disk:simulate{ q0 = { 0, 0, 0, 0 }, qd0 = { 0.9, 0, 0.7, 3 }, t1 = 10, dt = 0.05 }
roll:animate{ view = "3d", frames = 30, links = false, width = 50, height = 20 }]])
      f:close()
      drive(("notebook %s %s"):format(cells, nb))
      local code, out, err = h.run(("cd %s && %s -m nbconvert --to html scene.ipynb"):format(dir, PYTHON))
      assert(code == 0, out .. err)
      local page = dir .. "/scene.html"
      local tool = env .. PYTHON .. " tools/notebook.py "
      -- after the page's scripts ran: each scene drawn by WebGL (the player
      -- says so on its root once it rendered), not left at its GIF
      local dom
      code, dom = h.run(tool .. "dom " .. page)
      assert(code == 0)
      local states = {}
      for state in dom:gmatch('class="nzlua%-3d"[^>]-data%-nz%-view="([^"]*)"') do states[#states + 1] = state end
      if #states == 0 then for state in dom:gmatch('data%-nz%-view="([^"]*)"') do states[#states + 1] = state end end
      assert(#states == 2 and states[1] == "webgl" and states[2] == "webgl", "the scenes: " .. table.concat(states, ", "))
      -- the picture: each scene's body shaded in its colour (#9400D3 and
      -- lighter and darker), many shades of it: a lit ellipsoid, not a
      -- flat GIF
      local png = dir .. "/scene.png"
      code, out, err = h.run(tool .. "screenshot " .. page .. " " .. png .. " 1000 1300")
      assert(code == 0, out .. err)
      local shot = drive("pixels " .. png)
      assert(shot.purple > 2000, "the bodies are not drawn: " .. shot.purple .. " purple pixels")
      assert(shot.purple_shades > 40, "flat colour, not a lit scene: " .. shot.purple_shades .. " shades of purple")
    end)

    it("renders the example notebook: mathematics typeset by MathJax, the plot drawn", function()
      if not io.open(chromium) then pending("Debian's chromium is not installed (make deps)") return end
      local nb, html, png = dir .. "/classroom.ipynb", dir .. "/classroom.html", dir .. "/classroom.png"
      local tool = env .. PYTHON .. " tools/notebook.py "
      for _, step in ipairs{ "execute examples/classroom_pendulum.ipynb " .. nb, "html " .. nb .. " " .. html,
          "screenshot " .. html .. " " .. png } do
        local code, out, err = h.run(tool .. step)
        assert(code == 0, step .. ":\n" .. out .. err)
      end
      -- what the text says nzlua finds, it finds: m l^2 th'' + m g l sin th = 0, with the params' symbols
      local run = drive("read " .. nb)
      local shown, text, view = nil, "", nil
      for _, c in ipairs(run.cells) do
        if c.type == "markdown" then text = text .. c.source end
        for _, o in ipairs(c.outputs) do
          assert(o.type ~= "error", "a cell of the example failed: " .. c.source .. "\n" .. tostring(o.evalue))
          if o.data and c.source:find("pend:show{}", 1, true) then shown = o.data["text/plain"] end
          if o.data and c.source:find('view = "3d"', 1, true) then view = o.data["text/html"] end
        end
      end
      assert(text:find("m l^2 \\ddot\\theta + m g l \\sin\\theta = 0", 1, true), "the text's equation changed")
      assert(shown and shown:find("th:  l^2 m th'' + g l m sin(th) = 0", 1, true), tostring(shown))
      assert(view and view:find("nzlua-3d", 1, true), "no 3-D view of the top")
      local page = assert(h.slurp(html))
      assert(page:find('<img src="data:image/svg+xml;base64,', 1, true) and page:find("released from 1 rad", 1, true),
        "the page has no plot")
      assert(page:find('class="nzlua-3d"', 1, true), "the page has no 3-D scene")
      assert(page:find("file:///usr/share/javascript/mathjax/MathJax.js", 1, true), "MathJax is not the local one")
      -- after its scripts ran: MathJax replaced the LaTeX by its own elements
      local code, dom = h.run(tool .. "dom " .. html)
      assert(code == 0)
      local _, typeset = dom:gsub('class="mjx%-chtml', "")
      assert(typeset >= 5 and dom:find("MJXc-display", 1, true), "MathJax typeset " .. typeset .. " formulas")
      -- the equation's theta, as MathJax's own MathML of the LaTeX says it
      assert(dom:find("<mi>θ</mi>", 1, true), "no theta typeset")
      -- the picture: not blank, and the plot's first series in its colour (#9400D3, plot.lua's palette)
      local shot = drive("pixels " .. png)
      assert(shot.colours > 50, "a blank screenshot: " .. shot.colours .. " colours")
      assert(shot.purple > 100, "the plot's purple curve is not on the page: " .. shot.purple .. " pixels")
    end)
  end)
end)

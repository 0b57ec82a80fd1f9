-- nz/session/kernel.lua - nzlua's end of the Jupyter kernel: the requests that
-- jupyter/nzlua_kernel.py (an ipykernel wrapper kernel) sends over the pipe
-- of `nzlua --kernel-io`, answered by the same session the terminal has.
-- src/app/kernel_io.c moves the frames and lends `host`: read, write, run
-- (a function run as the session runs a chunk: SIGINT interrupts it as
-- Ctrl-C does) and complete (the session's Tab).  docs/kernel.md has the
-- protocol.
--
-- The notebook is a front-end (nz/base/frontend.lua) that renders every type of
-- the display layer (nz/draw/display.lua): a cell's last value comes as a
-- "result" bundle, a plot or an animation as a "display" bundle, and what
-- print and io.write write as "stream" frames, as they are written.
local display = require "nz.draw.display"
local frontend = require "nz.base.frontend"
local repl = require "nz.session.repl"

local M = {}

-- What a notebook renders: every type a bundle can hold.
M.ACCEPTS = {}
for _, mime in ipairs(display.MIMES) do M.ACCEPTS[mime] = true end

-- A bundle's data as the fields of a frame, in display.MIMES's order.
local function fields(data)
  local list = {}
  for _, mime in ipairs(display.MIMES) do
    if data[mime] then list[#list + 1], list[#list + 2] = mime, data[mime] end
  end
  return list
end

-- The front-end of a notebook whose frames go through `host`.
function M.frontend(host)
  local fe = { name = "jupyter", accepts = M.ACCEPTS }
  function fe.publish(data, kind) host.write(kind == "result" and "result" or "display", fields(data)) end
  function fe.print(text) display.show(display.of(text)) end
  function fe.progress() return true end   -- the notebook shows stderr's \r as a line redrawn
  return fe
end

-- Cells ---------------------------------------------------------------------

-- A cell's chunk, named "In [n]" so that messages say where: the
-- session's way (nz/session/repl.lua's chunk), the last expression's value shown.
M.chunk = repl.chunk

-- "In [3]:2:" as a person reads it: "In [3], line 2:".
function M.located(msg) return (msg:gsub("In %[(%d+)%]:(%d+):", "In [%1], line %2:")) end

-- `name?` or `?name` (IPython's habit) asks for help(name).
local function help_request(code)
  local name = code:match("^%s*%?%s*([%a_][%w_.:]*)%s*$") or code:match("^%s*([%a_][%w_.:]*)%s*%?%s*$")
  return name and ("help(%s)"):format((name:gsub(":", ".")))
end

-- A request that cannot be answered: the "done" frame of a protocol error
-- (the session goes on).
local function protocol_error(host, msg)
  msg = "kernel-io: " .. msg
  host.write("done", { "status", "error", "ename", "protocol", "evalue", msg, "traceback", msg })
end

-- The field `name` of a request as a whole number from lo to hi (default
-- when it is absent), or nil and why not: decimal digits alone, so that
-- 1e999, 1e300, -99999999999999999999 or abc never reach a format or a
-- C function that wants an integer.
local function whole(req, name, default, lo, hi)
  local s = req[name]
  if s == nil then return default end
  local n = s:match("^%-?%d+$") and math.tointeger(tonumber(s))
  if n and n >= lo and n <= hi then return n end
  return nil, ("field '%s' must be a whole number from %d to %d, got '%s'"):format(name, lo, hi, s:sub(1, 40))
end

local function execute(host, req)
  local cell, why = whole(req, "cell", 0, 0, math.maxinteger)
  if not cell then return protocol_error(host, why) end
  local name = ("In [%d]"):format(cell)
  local code = help_request(req.code or "") or req.code or ""
  local f, err = M.chunk(code, name)
  if not f then
    host.write("done", { "status", "error", "ename", "syntax error", "evalue", M.located(err), "traceback", M.located(err) })
    return
  end
  repl.begin()
  -- "started" is written inside the run: the kernel passes the stop button
  -- on once it has read it, and only inside the run is SIGINT Ctrl-C
  -- (between requests nzlua ignores it), so a stop that comes at once is
  -- never lost
  local res = table.pack(host.run(function()
    host.write("started", {})
    return f()
  end))
  local ok, interrupted = res[1], res[2]
  if ok then
    -- the value shown once, as the session shows it; built under run too
    -- (a value's __tostring is user code: Ctrl-C and errors as in a cell)
    local shown = table.pack(host.run(function()
      local b = repl.result(table.unpack(res, 3, res.n))
      if b then display.show(b, "result") end
    end))
    if not shown[1] then ok, res = false, shown end
    interrupted = interrupted or shown[2]
  end
  if ok and not interrupted then
    host.write("done", { "status", "ok" })
    return
  end
  local msg = ok and "interrupted: Ctrl-C stopped a computation, and the cell went on to its end "
    .. "(a simulate that it stopped returned its partial trajectory, also in nz.last)" or M.located(res[3])
  host.write("done", { "status", "error", "ename", interrupted and "interrupted" or "error",
    "evalue", msg:match("^[^\n]*"), "traceback", msg })
end

-- Completion and inspection -------------------------------------------------

local function complete(host, req)
  local code = req.code or ""
  local cursor, why = whole(req, "cursor", #code, 0, #code)
  if not cursor then return protocol_error(host, why) end
  local list, start = host.complete(code, cursor)
  table.sort(list)
  local unique = {}
  for _, s in ipairs(list) do
    if unique[#unique] ~= s then unique[#unique + 1] = s end
  end
  host.write("completion", { "matches", table.concat(unique, "\n"), "start", tostring(start), "end", tostring(cursor) })
end

-- The value a dotted name (nz.simulate, sys:simulate, tr.plot) names, or
-- nil; looked up as the completer does, under pcall.
local function lookup(path)
  local v = _G
  for part in path:gmatch("[^.:]+") do
    local ok, x = pcall(function() return v[part] end)
    if not ok or x == nil then return nil end
    v = x
  end
  return v
end

-- Shift-Tab: help on the name under (or just before) the cursor.
local function inspect(host, req)
  local code = req.code or ""
  local cursor, why = whole(req, "cursor", #code, 0, #code)
  if not cursor then return protocol_error(host, why) end
  local _, start = host.complete(code, cursor)
  local stop = cursor
  while stop < #code and code:sub(stop + 1, stop + 1):match("[%w_]") do stop = stop + 1 end
  local name = code:sub(start + 1, stop):match("^[%a_][%w_.:]*[%w_]$") or code:sub(start + 1, stop):match("^[%a_]$")
  local value = name and lookup(name)
  if value == nil then
    host.write("inspection", { "found", "false" })
    return
  end
  local ok, text = pcall(host.nz.help, value, { quiet = true })
  if not ok then text = tostring(text) end
  host.write("inspection", { "found", "true", "text/plain", text })
end

-- Whether a cell is whole (for a console front-end's Enter).
local function is_complete(host, req)
  local code = req.code or ""
  local status = "complete"
  if not load("return " .. code) then
    local f, err = load(code)
    if not f then status = err:match("<eof>$") and "incomplete" or "invalid" end
  end
  host.write("completeness", { "status", status })
end

local handlers = { execute = execute, complete = complete, inspect = inspect, is_complete = is_complete }

-- print in a cell: as Lua's print (each value by tostring, tab-separated,
-- then a newline, to stdout), except that a text holding a table of nz's
-- (print(lin), print(sw)) is shown as typing the value shows it, with the
-- table as HTML beside the text.
function M.print(...)
  local parts = {}
  for i = 1, select("#", ...) do parts[i] = tostring((select(i, ...))) end
  local s = table.concat(parts, "\t")
  local html = display.html(s)
  if html then
    display.show(display.bundle{ ["text/plain"] = s, ["text/html"] = html })
  else
    io.stdout:write(s, "\n")
    io.stdout:flush()
  end
end

-- The loop: requests until stdin ends or "shutdown".  host: the frames'
-- functions (src/app/kernel_io.c) and host.nz, the library (this floor is
-- below the face that loads it).
function M.serve(host)
  frontend.use(M.frontend(host))
  display.keep_tables(true)
  _G.print = M.print
  local nz = host.nz
  host.write("hello", { "version", nz.version, "lua", _VERSION })
  while true do
    local kind, req = host.read()
    if kind == nil or kind == "shutdown" then break end
    local handler = handlers[kind]
    if kind == false then
      protocol_error(host, req)   -- a malformed frame, skipped
    elseif handler then
      handler(host, req)
    else
      protocol_error(host, ("unknown request '%s' (execute, complete, inspect, is_complete, shutdown)"):format(kind))
    end
  end
end

-- nzlua --install-kernel ------------------------------------------------------

local function json_string(s)
  return '"' .. s:gsub('[%c"\\]', function(c)
    return ({ ['"'] = '\\"', ["\\"] = "\\\\", ["\n"] = "\\n", ["\t"] = "\\t" })[c] or ("\\u%04x"):format(c:byte())
  end) .. '"'
end

local function quote(path) return "'" .. path:gsub("'", "'\\''") .. "'" end

local function fail(fmt, ...) error(("nzlua --install-kernel: " .. fmt):format(...), 0) end

-- Where the kernel spec goes: Jupyter's data directory for every user
-- (/usr/local/share/jupyter), the user's own (--user: $JUPYTER_DATA_DIR,
-- else $XDG_DATA_HOME/jupyter, else ~/.local/share/jupyter, as
-- jupyter_core finds it), or PREFIX/share/jupyter (--prefix, for packaging).
local function data_dir(opts)
  if opts.prefix then return opts.prefix .. "/share/jupyter" end
  if not opts.user then return "/usr/local/share/jupyter" end
  local env = os.getenv("JUPYTER_DATA_DIR")
  if env and env ~= "" then return env end
  local xdg, home = os.getenv("XDG_DATA_HOME"), os.getenv("HOME")
  if xdg and xdg ~= "" then return xdg .. "/jupyter" end
  if not home or home == "" then fail("--user: HOME is not set (give --prefix DIR instead)") end
  return home .. "/.local/share/jupyter"
end

-- args: the command line after --install-kernel, and .program (this
-- program's path, which the spec starts unless --nzlua PATH says another).
-- Writes DIR/kernels/nzlua/{kernel.json, nzlua_kernel.py}; returns the folder.
function M.install(args)
  local opts, i = { program = args.program }, 1
  while args[i] do
    local a = args[i]
    if a == "--user" then opts.user = true
    elseif a == "--prefix" or a == "--nzlua" or a == "--python" then
      if not args[i + 1] then fail("%s needs a value", a) end
      opts[a:sub(3)] = args[i + 1]
      i = i + 1
    else
      fail("unknown option '%s' (--user, --prefix DIR, --nzlua PATH, --python PATH)", a)
    end
    i = i + 1
  end
  if opts.user and opts.prefix then fail("--user and --prefix: give one of them") end
  local program = opts.nzlua or opts.program
  if not program or program == "" then fail("cannot tell where nzlua is: give --nzlua PATH") end
  -- Debian's python3 has Debian's ipykernel (another python3 on PATH may not)
  local python = opts.python or "/usr/bin/python3"
  local dir = data_dir(opts) .. "/kernels/nzlua"
  local ok = os.execute("mkdir -p " .. quote(dir))
  if not ok then fail("cannot create '%s'", dir) end
  local spec = table.concat({
    "{",
    '  "argv": [' .. table.concat({ json_string(python), json_string("{resource_dir}/nzlua_kernel.py"), json_string("--nzlua"),
      json_string(program), json_string("-f"), json_string("{connection_file}") }, ", ") .. "],",
    '  "display_name": "nzlua",',
    '  "language": "lua",',
    '  "interrupt_mode": "signal",',
    '  "metadata": { "debugger": false }',
    "}", "" }, "\n")
  for name, text in pairs{ ["kernel.json"] = spec, ["nzlua_kernel.py"] = require("nz.files.nzlua_kernel_py") } do
    local f, err = io.open(dir .. "/" .. name, "w")
    if not f then fail("cannot write '%s': %s", dir .. "/" .. name, err) end
    f:write(text)
    f:close()
  end
  -- three.js for tr:animate{ view = "3d" }, served by the notebook server
  -- from this folder (kernelspecs/nzlua/three.min.js): Debian's copy, linked
  local three = require("nz.draw.three").DEBIAN
  local note, found = "", io.open(three)
  if found then
    found:close()
    if not os.execute(("ln -sf %s %s"):format(quote(three), quote(dir .. "/three.min.js"))) then
      fail("cannot link '%s' into '%s'", three, dir)
    end
  else
    note = "; three.js is not installed (sudo apt-get install libjs-three): 3-D views show their GIF"
  end
  print(("nzlua: kernel spec 'nzlua' installed in %s (it starts %s)%s"):format(dir, program, note))
  return dir
end

return M

-- nz/motion/sweep.lua - nz.sweep{...}: the same system run at many points (a grid,
-- a list or a random sample of parameters and initial conditions), on every
-- core, with every finished point appended to a CSV file as it completes,
-- a resume that computes only the missing points, failures recorded with
-- their message; and the worker of `nzlua --sweep-worker`, which takes
-- points on stdin and writes result rows on stdout, so that GNU parallel (or
-- a Slurm job array) spreads a sweep over machines.
--
-- Workers are processes made by fork() (src/lua/lua_sweep.c): a Lua state
-- cannot be shared between threads, and a forked worker inherits the system
-- and the run function, closures and all, with nothing to serialize.  The
-- parent hands out one point index at a time over a socket and receives the
-- outputs packed exactly (string.pack: integers and doubles bit for bit), so
-- that jobs = 2 gives the numbers of jobs = 1.  jobs = 1 runs in the caller's
-- process.
local core = require "nz.core"
local mech = core.mech
local user_where = require("nz.base.where").user_where

local M = {}

-- Limits and timings (documented in help(nz.sweep)).
M.MAX_POINTS = 1e7       -- points of one sweep (a grid's product is checked first)
M.POLL_MS = 200          -- the parent looks at the clock (progress) at least this often
-- Cheap points (under AHEAD_BELOW seconds each, on average) are handed out
-- up to AHEAD at a time per worker, so that a worker never waits for the
-- parent between them; costlier ones one at a time, which balances best.
M.AHEAD, M.AHEAD_BELOW = 16, 0.002
M.FLUSH_S = 0.01         -- a worker holds finished results at most this long while it has points
M.PARALLEL_N = 10        -- points per GNU parallel job, unless the options say (-N, --block)
M.PROGRESS = { delay = 0.5, every = 0.2 }   -- the bar shows after delay s, redraws every s
M.DEFAULT_SEED = 1       -- sample = {n =, ranges =} without a seed

local known = require("nz.base.options").declare("nz.sweep", { system = true, file = true, grid = true, list = true, sample = true, run = true, jobs = true,
  out = true, resume = true, retry = true, progress = true, todo = true, from = true, parallel = true, worker = true })

local function fail(msg, ...) error(user_where() .. ("sweep: " .. msg):format(...), 0) end

local show, finite = require("nz.base.args").shown, require("nz.base.args").finite
-- A name in a message: "x y" quoted, anything else as a value.
local function name_shown(v) return type(v) == "string" and ("%q"):format(v) or show(v) end

local function is_name(s) return type(s) == "string" and s:match("^[%a_][%w_]*$") ~= nil and s ~= "error" end

local function sorted_keys(t)
  local keys = {}
  for k in pairs(t) do keys[#keys + 1] = k end
  table.sort(keys, function(a, b) return tostring(a) < tostring(b) end)
  return keys
end

----------------------------------------------------------------------------
-- Values as text: CSV cells and the worker's records

-- A number as the session prints it: the shortest of %.15g .. %.17g that
-- reads back exactly, an integral float keeping ".0" so that its type reads
-- back too (NaN, inf, -inf as words the parser below knows); strings are
-- quoted, so an unquoted cell is always a number or a boolean.
M.number = require("nz.base.text").number

local specials = { nan = 0 / 0, ["-nan"] = 0 / 0, NaN = 0 / 0, inf = math.huge, ["+inf"] = math.huge, ["-inf"] = -math.huge }

-- An unquoted token back to its value: a number, a boolean, or the text.
local function token_value(s)
  if s == "true" then return true elseif s == "false" then return false end
  local v = tonumber(s)
  if v ~= nil then return v end
  if specials[s] then return specials[s] end
  return s
end

local function csv_cell(v)
  if v == nil then return "" end
  if type(v) == "number" then return M.number(v) end
  if type(v) == "boolean" then return tostring(v) end
  return '"' .. tostring(v):gsub('"', '""') .. '"'
end

local function csv_line(names, row)
  local cells = {}
  for i, name in ipairs(names) do cells[i] = csv_cell(row[name]) end
  return table.concat(cells, ",") .. "\n"
end

-- RFC 4180 records of a text: a list of lists of values (quoted cells are
-- strings, empty ones nil); partial = true when the text ends inside a
-- record (a line cut short by a kill), which is left out.
function M.parse_csv(text, where)
  local records, pos, n, line = {}, 1, #text, 1
  while pos <= n do
    local fields, count = {}, 0
    while true do
      count = count + 1
      if text:sub(pos, pos) == '"' then
        local parts, i = {}, pos + 1
        while true do
          local q = text:find('"', i, true)
          if not q then return records, true end
          parts[#parts + 1] = text:sub(i, q - 1)
          if text:sub(q + 1, q + 1) == '"' then parts[#parts + 1] = '"'; i = q + 2
          else pos = q + 1; break end
        end
        fields[count] = table.concat(parts)
      else
        local e = text:find("[,\n]", pos)
        if not e then return records, true end
        local cell = text:sub(pos, e - 1):gsub("\r$", "")
        if cell ~= "" then fields[count] = token_value(cell) end
        pos = e
      end
      local d = text:sub(pos, pos)
      if d == "," then pos = pos + 1
      elseif d == "\n" then pos = pos + 1; break
      elseif d == "\r" and text:sub(pos + 1, pos + 1) == "\n" then pos = pos + 2; break
      elseif d == "" then return records, true
      else error(("%s:%d: malformed CSV (a character after a closing quote)"):format(where or "csv", line), 0) end
    end
    fields.n = count
    records[#records + 1] = fields
    line = line + 1
  end
  return records, false
end

-- The worker's record: name=value separated by spaces, one point or result
-- per line; a string value in double quotes with \\ \" \n \r escaped.
local escapes = { ["\\"] = "\\\\", ['"'] = '\\"', ["\n"] = "\\n", ["\r"] = "\\r" }
local unescapes = { ["\\"] = "\\", ['"'] = '"', n = "\n", r = "\r" }

local function record_value(v)
  if type(v) == "number" then return M.number(v) end
  if type(v) == "boolean" then return tostring(v) end
  return '"' .. tostring(v):gsub('[\\"\n\r]', escapes) .. '"'
end

function M.record_line(names, row)
  local parts = {}
  for _, name in ipairs(names) do
    if row[name] ~= nil then parts[#parts + 1] = name .. "=" .. record_value(row[name]) end
  end
  return table.concat(parts, " ") .. "\n"
end

-- One line back to a table of values and the names in their order; nil and
-- a reason when it is not a record.
function M.parse_record(line)
  local row, names, pos = {}, {}, 1
  while true do
    pos = line:find("[^%s,]", pos)
    if not pos then break end
    local name, vstart = line:match("^([%a_][%w_]*)=()", pos)
    if not name then return nil, ("expected name=value at column %d"):format(pos) end
    local value
    if line:sub(vstart, vstart) == '"' then
      local parts, i = {}, vstart + 1
      while true do
        local c = line:find('[\\"]', i)
        if not c then return nil, ("unterminated string for '%s'"):format(name) end
        parts[#parts + 1] = line:sub(i, c - 1)
        if line:sub(c, c) == '"' then pos = c + 1; break end
        local esc = unescapes[line:sub(c + 1, c + 1)]
        if not esc then return nil, ("bad escape in the string of '%s'"):format(name) end
        parts[#parts + 1] = esc
        i = c + 2
      end
      value = table.concat(parts)
    else
      local e = line:find("[%s,]", vstart) or #line + 1
      local text = line:sub(vstart, e - 1)
      if text == "" then return nil, ("no value for '%s'"):format(name) end
      value = token_value(text)
      pos = e
    end
    if row[name] == nil then names[#names + 1] = name end
    row[name] = value
  end
  return row, names
end

----------------------------------------------------------------------------
-- The points

-- splitmix64 (Steele, Lea, Flood 2014): the same sample on every machine
-- and in every Lua, whatever math.random's state.
local function splitmix(seed)
  local state = seed
  return function()
    state = state + 0x9E3779B97F4A7C15
    local z = state
    z = (z ~ (z >> 30)) * 0xBF58476D1CE4E5B9
    z = (z ~ (z >> 27)) * 0x94D049BB133111EB
    z = z ~ (z >> 31)
    return (z >> 11) * 2.0 ^ -53
  end
end

local function input_value(v) return (type(v) == "number" and v == v) or type(v) == "string" or type(v) == "boolean" end

local function grid_points(grid)
  if type(grid) ~= "table" or next(grid) == nil then fail("'grid' must be a table {name = {values...}, ...}, got %s", show(grid)) end
  local names, total = sorted_keys(grid), 1
  for _, name in ipairs(names) do
    if not is_name(name) then fail("grid name %s must be a name (letters, digits, _; not 'error')", name_shown(name)) end
    local values = grid[name]
    if type(values) ~= "table" or #values == 0 then
      fail("'grid.%s' must be a non-empty list of values, got %s", name, show(values))
    end
    for i, v in ipairs(values) do
      if not input_value(v) then fail("'grid.%s'[%d] must be a number (not NaN) or a string, got %s", name, i, show(v)) end
    end
    total = total * #values
  end
  if total > M.MAX_POINTS then fail("the grid has %.3g points; at most %g", total, M.MAX_POINTS) end
  local points = {}
  for i = 0, total - 1 do          -- the first name varies slowest
    local p, rest = {}, i
    for j = #names, 1, -1 do
      local values = grid[names[j]]
      p[names[j]] = values[rest % #values + 1]
      rest = rest // #values
    end
    points[i + 1] = p
  end
  return points, names
end

local function list_points(list)
  if type(list) ~= "table" or #list == 0 then fail("'list' must be a non-empty list of points {name = value, ...}, got %s", show(list)) end
  local names
  for i, p in ipairs(list) do
    if type(p) ~= "table" or next(p) == nil then fail("'list'[%d] must be a point {name = value, ...}, got %s", i, show(p)) end
    local these = sorted_keys(p)
    for _, name in ipairs(these) do
      if not is_name(name) then fail("'list'[%d]: %s must be a name (letters, digits, _; not 'error')", i, name_shown(name)) end
      if not input_value(p[name]) then fail("'list'[%d].%s must be a number (not NaN) or a string, got %s", i, name, show(p[name])) end
    end
    names = names or these
    if table.concat(these, ",") ~= table.concat(names, ",") then
      fail("'list'[%d] has the names {%s}, the first point {%s}: every point gives the same names", i,
        table.concat(these, ", "), table.concat(names, ", "))
    end
  end
  if #list > M.MAX_POINTS then fail("the list has %d points; at most %g", #list, M.MAX_POINTS) end
  local points = {}
  for i, p in ipairs(list) do
    points[i] = {}
    for k, v in pairs(p) do points[i][k] = v end
  end
  return points, names
end

local function sample_points(s)
  if type(s) ~= "table" then fail("'sample' must be {n =, seed =, ranges = {name = {low, high}, ...}}, got %s", show(s)) end
  for key in pairs(s) do
    if key ~= "n" and key ~= "seed" and key ~= "ranges" then fail("unknown field 'sample.%s' (fields: n, seed, ranges)", tostring(key)) end
  end
  local whole = math.type(s.n) == "integer" or (finite(s.n) and s.n == math.floor(s.n))
  if not whole or s.n < 1 then
    fail("'sample.n' (the number of points) must be a positive integer, got %s", show(s.n))
  end
  if s.n > M.MAX_POINTS then fail("'sample.n' = %d points; at most %g", s.n, M.MAX_POINTS) end
  local seed = s.seed == nil and M.DEFAULT_SEED or s.seed
  if math.type(seed) ~= "integer" then fail("'sample.seed' must be an integer, got %s", show(s.seed)) end
  if type(s.ranges) ~= "table" or next(s.ranges) == nil then
    fail("'sample.ranges' must be {name = {low, high}, ...}, got %s", show(s.ranges))
  end
  local names = sorted_keys(s.ranges)
  for _, name in ipairs(names) do
    local r = s.ranges[name]
    if not is_name(name) then fail("sample name %s must be a name (letters, digits, _; not 'error')", name_shown(name)) end
    if type(r) ~= "table" or not finite(r[1]) or not finite(r[2]) or not (r[1] <= r[2]) then
      fail("'sample.ranges.%s' must be {low, high} with finite low <= high, got %s", name,
        type(r) == "table" and ("{%s, %s}"):format(show(r[1]), show(r[2])) or show(r))
    end
  end
  local u, points = splitmix(seed), {}
  for i = 1, math.tointeger(s.n) do
    local p = {}
    for _, name in ipairs(names) do
      local r = s.ranges[name]
      p[name] = r[1] + (r[2] - r[1]) * u()
    end
    points[i] = p
  end
  return points, names
end

-- The identity of a point: its inputs as exact text (a point read back from
-- a file is the same point).
local function point_key(names, p)
  local parts = {}
  for i, name in ipairs(names) do parts[i] = record_value(p[name]) end
  return table.concat(parts, ",")
end

----------------------------------------------------------------------------
-- One point

-- Set the point's names that are parameters of the system, call run on a
-- copy of the point; the outputs (a flat table) or nil and the message.
-- An interrupt (nz.interrupted) is raised again: it is not the point's failure.
local function evaluate(sys, run, point, inputs)
  if sys then
    for name, v in pairs(point) do if sys.params[name] ~= nil then sys.params[name] = v end end
  end
  local p = {}
  for k, v in pairs(point) do p[k] = v end
  local ok, out = pcall(run, sys, p)
  if not ok then
    if rawequal(out, core.interrupted) then error(out, 0) end
    return nil, tostring(out)
  end
  if type(out) ~= "table" then
    return nil, ("run returned %s; a table of outputs {name = number, ...} expected"):format(show(out))
  end
  local res = {}
  for k, v in pairs(out) do
    if not is_name(k) then return nil, ("run returned the output name %s: names are letters, digits and _ (not 'error')"):format(name_shown(k)) end
    if inputs[k] then return nil, ("run returned '%s', which is an input of the sweep: name the output differently"):format(k) end
    if type(v) ~= "number" and type(v) ~= "string" and type(v) ~= "boolean" then
      return nil, ("run returned %s for '%s'; outputs are numbers, strings or booleans"):format(show(v), k)
    end
    res[k] = v
  end
  return res
end

-- Outputs packed exactly (integers and doubles keep every bit).
local function pack_result(i, out, err)
  if not out then return string.pack("<jBs4", i, 1, err) end
  local parts = { string.pack("<jB", i, 0) }
  for k, v in pairs(out) do
    if math.type(v) == "integer" then parts[#parts + 1] = string.pack("<s4Bj", k, 1, v)
    elseif type(v) == "number" then parts[#parts + 1] = string.pack("<s4Bn", k, 2, v)
    elseif type(v) == "string" then parts[#parts + 1] = string.pack("<s4Bs4", k, 3, v)
    else parts[#parts + 1] = string.pack("<s4BB", k, 4, v and 1 or 0) end
  end
  return table.concat(parts)
end

local function unpack_result(s)
  local i, failed, pos = string.unpack("<jB", s)
  if failed == 1 then return i, nil, (string.unpack("<s4", s, pos)) end
  local out, key, kind, v = {}, nil, nil, nil
  while pos <= #s do
    key, kind, pos = string.unpack("<s4B", s, pos)
    if kind == 1 then v, pos = string.unpack("<j", s, pos)
    elseif kind == 2 then v, pos = string.unpack("<n", s, pos)
    elseif kind == 3 then v, pos = string.unpack("<s4", s, pos)
    else v, pos = string.unpack("<B", s, pos); v = v == 1 end
    out[key] = v
  end
  return i, out
end

----------------------------------------------------------------------------
-- The results file: a header (the inputs, the outputs, error), one row per
-- finished point, appended and flushed as each one comes.

local Writer = {}
Writer.__index = Writer

-- Rows of an existing sweep file, or nil when there is none.
local function read_results(path)
  local f = io.open(path, "rb")
  if not f then return nil end
  local text = f:read("a")
  f:close()
  if text == "" then return nil end
  local records, partial = M.parse_csv(text, path)
  if #records == 0 then return nil end
  local header = records[1]
  for j = 1, header.n do
    if type(header[j]) ~= "string" then return { bad = ("its header cell %d is not a name"):format(j) } end
  end
  local columns, rows = {}, {}
  for j = 1, header.n do columns[j] = header[j] end
  for r = 2, #records do
    local rec, row = records[r], {}
    for j, name in ipairs(columns) do row[name] = rec[j] end
    rows[#rows + 1] = row
  end
  return { columns = columns, rows = rows, partial = partial }
end

function Writer.new(path, inputs, existing)
  local w = setmetatable({ path = path, inputs = inputs, outputs = {}, known = {}, rows = {} }, Writer)
  if existing then
    for j = #inputs + 1, #existing.columns - 1 do
      local name = existing.columns[j]
      w.outputs[#w.outputs + 1], w.known[name] = name, true
    end
    w.rows = existing.rows
    if existing.partial then w:rewrite() end   -- a line cut short: the file without it
    w.file = assert(io.open(path, "ab"))
  end
  return w
end

function Writer:columns()
  local c = {}
  for _, n in ipairs(self.inputs) do c[#c + 1] = n end
  for _, n in ipairs(self.outputs) do c[#c + 1] = n end
  c[#c + 1] = "error"
  return c
end

-- The whole file again beside its target, renamed into place (a header with
-- a new output, or a file whose last line was cut short).
function Writer:rewrite()
  if self.file then self.file:close(); self.file = nil end
  local tmp = mech.temp_beside(self.path)
  if not tmp then fail("cannot write the results file '%s'", self.path) end
  local f = assert(io.open(tmp, "wb"))
  local cols = self:columns()
  local parts = { table.concat(cols, ",") .. "\n" }
  for _, row in ipairs(self.rows) do parts[#parts + 1] = csv_line(cols, row) end
  f:write(table.concat(parts))
  f:close()
  mech.hold_term(true)
  local ok, err = os.rename(tmp, self.path)
  mech.hold_term(false)
  if not ok then os.remove(tmp); fail("cannot write the results file '%s': %s", self.path, err) end
  self.file = assert(io.open(self.path, "ab"))
end

function Writer:append(row)
  local new = {}
  for k in pairs(row) do
    if not self.known[k] and k ~= "error" then
      local input = false
      for _, n in ipairs(self.inputs) do if n == k then input = true end end
      if not input then new[#new + 1] = k end
    end
  end
  self.rows[#self.rows + 1] = row
  if #new > 0 then
    table.sort(new)
    for _, k in ipairs(new) do self.outputs[#self.outputs + 1], self.known[k] = k, true end
    if self.file or #self.rows > 1 then return self:rewrite() end
  end
  if not self.file then
    local f, err = io.open(self.path, "wb")
    if not f then fail("cannot write the results file: %s", err) end
    self.file = f
    f:write(table.concat(self:columns(), ","), "\n")
  end
  self.file:write(csv_line(self:columns(), row))
  self.file:flush()
end

function Writer:close()
  if self.file then self.file:close(); self.file = nil end
end

----------------------------------------------------------------------------
-- Progress on a terminal: done/total, failures, the time left.

local function progress_bar(enabled, total)
  if enabled == nil then enabled = require("nz.base.frontend").progress() end   -- a terminal, or a notebook
  if not enabled or total == 0 then return function() end, function() end end
  local start, last, shown = mech.now(), 0, false
  local function update(done, failed)
    local now = mech.now()
    if now - start < M.PROGRESS.delay or now - last < M.PROGRESS.every then return end
    last, shown = now, true
    local frac, width = done / total, 30
    local fill = math.floor(frac * width + 0.5)
    local left = done > 0 and (now - start) / done * (total - done) or nil
    local eta = not left and "?" or left < 90 and ("%.0f s"):format(left) or left < 5400 and ("%.1f min"):format(left / 60)
      or ("%.1f h"):format(left / 3600)
    io.stderr:write(("\r[%s%s] %d/%d points%s, %s left  (Ctrl-C stops, keeping what is done)\27[K")
      :format(("#"):rep(fill), (" "):rep(width - fill), done, total,
        failed > 0 and (" (%d failed)"):format(failed) or "", eta))
  end
  local function done()
    if shown then io.stderr:write("\r\27[K") end
  end
  return update, done
end

----------------------------------------------------------------------------
-- Running the points

-- In this process (jobs = 1).
local function run_here(ctx, queue, finished)
  for _, i in ipairs(queue) do
    if mech.interrupted() then error(core.interrupted, 0) end
    local out, err = evaluate(ctx.sys, ctx.run, ctx.points[i], ctx.input_set)
    finished(i, out, err)
  end
end

-- The worker's side of a fork: point indices in, packed results out, until
-- the parent closes the socket.  Results wait while more points are at hand
-- (at most M.FLUSH_S seconds), so that cheap points cost one send per batch;
-- all are sent before the worker waits for more.
local function worker_loop(ctx, fd)
  local buf, ready, last = "", {}, mech.now()
  local function flush()
    if #ready == 0 then return true end
    local ok = mech.sweep_send(fd, table.concat(ready))
    ready, last = {}, mech.now()
    return ok
  end
  while true do
    if #buf < 8 and not flush() then return end
    while #buf < 8 do
      local s = mech.sweep_recv(fd)
      if not s then return end
      buf = buf .. s
    end
    local i = string.unpack("<j", buf)
    buf = buf:sub(9)
    local out, err = evaluate(ctx.sys, ctx.run, ctx.points[i], ctx.input_set)
    ready[#ready + 1] = string.pack("<s4", pack_result(i, out, err))
    if mech.now() - last > M.FLUSH_S and not flush() then return end
  end
end

-- In worker processes.  The next point goes to whichever worker is free,
-- so points of very different cost balance themselves; cheap points go
-- several at a time (M.AHEAD) while many remain.
local function run_forked(ctx, queue, jobs, finished, tick)
  local workers, byfd, nextq = {}, {}, 1
  local start, ndone = mech.now(), 0
  local function spawn()
    local pid, fd = mech.sweep_fork()
    if not pid then error(("sweep: cannot start a worker process (%s)"):format(fd), 0) end
    if pid == 0 then                   -- the worker: never returns into the caller
      for _, w in ipairs(workers) do if w.fd then mech.sweep_close(w.fd) end end
      local ok, err = pcall(worker_loop, ctx, fd)
      if not ok then io.stderr:write("sweep worker: ", tostring(err), "\n") end
      mech.sweep_exit(ok and 0 or 1)
    end
    local w = { pid = pid, fd = fd, buf = "", pending = {} }
    workers[#workers + 1], byfd[fd] = w, w
    return w
  end
  local function retire(w)
    if w.fd then mech.sweep_close(w.fd); byfd[w.fd] = nil; w.fd = nil end
  end
  local function assign(w)
    local ahead = 1
    if ndone >= jobs and (mech.now() - start) * jobs / ndone < M.AHEAD_BELOW then
      ahead = math.max(1, math.min(M.AHEAD, (#queue - nextq + 1) // (2 * jobs)))
    end
    local send = {}
    while #w.pending < ahead and nextq <= #queue do
      local i = queue[nextq]
      nextq = nextq + 1
      w.pending[#w.pending + 1], send[#send + 1] = i, string.pack("<j", i)
    end
    if #send > 0 and not w.lost and not mech.sweep_send(w.fd, table.concat(send)) then w.lost = true end
    if #w.pending == 0 then retire(w) end
  end
  local function reap(w)
    if w.reaped then return end
    local how, code = mech.sweep_wait(w.pid)
    w.reaped, w.how, w.code = true, how, code
  end
  local function cleanup()
    for _, w in ipairs(workers) do
      if not w.reaped then
        retire(w)
        mech.sweep_kill(w.pid, "term")
        reap(w)
      end
    end
  end
  local ok, err = pcall(function()
    for _ = 1, math.min(jobs, #queue) do assign(spawn()) end
    while true do
      local fds = {}
      for _, w in ipairs(workers) do
        if w.fd and #w.pending > 0 then fds[#fds + 1] = w.fd end
      end
      if #fds == 0 then break end
      local ready = mech.sweep_poll(fds, M.POLL_MS)
      if ready == false then error(core.interrupted, 0) end
      for _, fd in ipairs(ready) do
        local w = byfd[fd]
        local s = mech.sweep_recv(fd)
        if s == nil or w.lost then
          -- the worker died: the point it was running fails, those waiting
          -- for it go back to the queue
          retire(w)
          reap(w)
          local i = table.remove(w.pending, 1)
          for _, j in ipairs(w.pending) do queue[#queue + 1] = j end
          w.pending = {}
          finished(i, nil, ("the worker process died (%s %d) while computing this point"):format(
            w.how == "signal" and "signal" or "exit status", w.code or -1))
          if nextq <= #queue then assign(spawn()) end
        else
          w.buf = w.buf .. s
          while #w.buf >= 4 do
            local len = string.unpack("<I4", w.buf)
            if #w.buf < 4 + len then break end
            local i, out, e = unpack_result(w.buf:sub(5, 4 + len))
            w.buf = w.buf:sub(5 + len)
            assert(table.remove(w.pending, 1) == i, "sweep: a worker answered for another point")
            ndone = ndone + 1
            finished(i, out, e)
          end
          assign(w)
        end
      end
      tick()
    end
    for _, w in ipairs(workers) do retire(w); reap(w) end
  end)
  if not ok then
    cleanup()
    error(err, 0)
  end
end

-- Through GNU parallel: the missing points go to a temporary file, which
-- `parallel --pipe OPTIONS` cuts into jobs of `WORKER --sweep-worker FILE`
-- on the hosts its options name; its output is read line by line as the
-- jobs finish.  Returns the number of points no job answered for, and how
-- parallel ended.  Ctrl-C at a terminal reaches parallel too (the same
-- process group), which ends its jobs; the rows read so far are kept.
local function shell_quote(text) return "'" .. text:gsub("'", "'\\''") .. "'" end

local function run_parallel(ctx, queue, finished, opts, inputs)
  if not os.execute("command -v parallel >/dev/null 2>&1") then
    fail("'parallel': GNU parallel is not installed (sudo apt-get install parallel, or make deps)")
  end
  local file = opts.file
  if file:sub(1, 1) ~= "/" then file = (os.getenv("PWD") or ".") .. "/" .. file end
  local todo = os.tmpname()
  local f = assert(io.open(todo, "wb"))
  local index, missing = {}, 0
  for _, i in ipairs(queue) do
    f:write(M.record_line(inputs, ctx.points[i]))
    index[point_key(inputs, ctx.points[i])] = i
    missing = missing + 1
  end
  f:close()
  local popts = opts.parallel
  if not (popts:find("%-N") or popts:find("%-%-max%-replace%-args") or popts:find("%-%-block")) then
    popts = popts .. " -N " .. M.PARALLEL_N
  end
  local cmd = ("parallel --pipe %s %s --sweep-worker %s < %s"):format(popts, opts.worker or "nzlua", shell_quote(file),
    shell_quote(todo))
  local p = assert(io.popen(cmd, "r"))
  local ok, err = pcall(function()
    for line in p:lines() do
      local row = M.parse_record(line)
      local key = row and point_key(inputs, row)
      local i = key and index[key]
      if i then
        index[key], missing = nil, missing - 1
        local out = {}
        for k, v in pairs(row) do if not ctx.input_set[k] and k ~= "error" then out[k] = v end end
        finished(i, row.error == nil and out or nil, row.error)
      else
        io.stderr:write("sweep: a line of GNU parallel's output that is no point of this sweep: ", line, "\n")
      end
    end
  end)
  local _, how, code = p:close()
  os.remove(todo)
  if not ok then error(err, 0) end
  return missing, how, code
end

----------------------------------------------------------------------------
-- nz.sweep

local function check_options(opts)
  if type(opts) ~= "table" then fail("options {system =, grid =, run =, ...} expected, got %s", show(opts)) end
  require("nz.base.options").check(opts, known, fail)
  local given = {}
  for _, key in ipairs{ "grid", "list", "sample" } do if opts[key] ~= nil then given[#given + 1] = key end end
  if #given ~= 1 then
    fail(#given == 0 and "no points: give 'grid', 'list' or 'sample'" or "give one of 'grid', 'list', 'sample', not %s",
      table.concat(given, " and "))
  end
  for _, key in ipairs{ "out", "todo" } do
    if opts[key] ~= nil and (type(opts[key]) ~= "string" or opts[key] == "") then
      fail("'%s' must be a file name, got %s", key, show(opts[key]))
    end
  end
  for _, key in ipairs{ "resume", "retry", "progress" } do
    if opts[key] ~= nil and type(opts[key]) ~= "boolean" then fail("'%s' must be true or false, got %s", key, show(opts[key])) end
  end
  if opts.jobs ~= nil and (math.type(opts.jobs) ~= "integer" or opts.jobs < 1) then
    fail("'jobs' (worker processes) must be a positive integer, got %s", show(opts.jobs))
  end
  if opts.from ~= nil then
    local list = type(opts.from) == "string" and { opts.from } or opts.from
    if type(list) ~= "table" or #list == 0 then fail("'from' must be a file name or a list of them, got %s", show(opts.from)) end
    for _, name in ipairs(list) do
      if type(name) ~= "string" then fail("'from' must be a file name or a list of them, got %s", show(name)) end
    end
  end
  if opts.retry and not opts.out then fail("'retry' needs 'out', the file whose failed points are computed again") end
  for _, key in ipairs{ "parallel", "worker" } do
    if opts[key] ~= nil and type(opts[key]) ~= "string" then fail("'%s' must be a string, got %s", key, show(opts[key])) end
  end
  if opts.worker and not opts.parallel then fail("'worker' (the command on the hosts) goes with 'parallel'") end
  if opts.parallel then
    if not opts.file then
      fail("'parallel' needs 'file': the hosts load the system and run from it (what is given inline stays in this process)")
    end
    if opts.todo then fail("give 'parallel' or 'todo', not both") end
  end
end

-- The system and the run function, from the options or from a file that
-- returns a system or {system = sys, run = function(sys, point) ... end}.
local function load_file(file)
  if type(file) ~= "string" then fail("'file' must be the name of a Lua file, got %s", show(file)) end
  local chunk, err = loadfile(file)
  if not chunk then fail("cannot load 'file' (%s)", err) end
  local ok, v = pcall(chunk)
  if not ok then fail("'file' %s failed: %s", file, tostring(v)) end
  local System = require("nz.base.classes").System
  if getmetatable(v) == System then return v, nil end
  if type(v) == "table" and getmetatable(v) == nil and (v.system ~= nil or v.run ~= nil) then
    if v.system ~= nil and getmetatable(v.system) ~= System then
      fail("'file' %s returned {system = %s}: a system made by nz.system or nz.scene expected", file, show(v.system))
    end
    if v.run ~= nil and type(v.run) ~= "function" then fail("'file' %s returned {run = %s}: a function expected", file, show(v.run)) end
    return v.system, v.run
  end
  fail("'file' %s must return a system or {system = sys, run = function(sys, point) ... end}, got %s", file, show(v))
end

local function resolve(opts)
  if opts.system ~= nil and opts.file ~= nil then fail("give 'system' or 'file', not both") end
  local sys, run = opts.system, opts.run
  if opts.file ~= nil then
    local fsys, frun = load_file(opts.file)
    sys, run = fsys, run or frun
  elseif sys ~= nil and not require("nz.base.classes").is_system(sys) then
    fail("'system' must be a system made by nz.system or nz.scene, got %s", show(sys))
  end
  if run ~= nil and type(run) ~= "function" then
    fail("'run' must be a function(sys, point) returning a table of outputs, got %s", show(run))
  end
  return sys, run
end

-- Rows of other files (a GNU parallel run's records, a Slurm task's, another
-- sweep's CSV), by point key.
local function read_from(files, inputs)
  local found = {}
  for _, name in ipairs(type(files) == "string" and { files } or files) do
    local f = io.open(name, "rb")
    if not f then fail("'from': cannot read %s", name) end
    local text = f:read("a")
    f:close()
    local first = text:match("^[^\n]*")
    if first:find("=", 1, true) then                       -- records
      local n = 0
      for line in text:gmatch("[^\n]+") do
        n = n + 1
        if not line:match("^%s*#") and line:match("%S") then
          local row, why = M.parse_record(line)
          if not row then fail("'from' %s:%d: %s", name, n, why) end
          found[point_key(inputs, row)] = row
        end
      end
    else
      local res = read_results(name)
      if res and res.bad then fail("'from' %s: not a sweep's results (%s)", name, res.bad) end
      for _, row in ipairs(res and res.rows or {}) do found[point_key(inputs, row)] = row end
    end
  end
  return found
end

function M.sweep(opts)
  if mech.interrupted() then error(core.interrupted, 0) end
  check_options(opts)
  local points, inputs
  if opts.grid ~= nil then points, inputs = grid_points(opts.grid)
  elseif opts.list ~= nil then points, inputs = list_points(opts.list)
  else points, inputs = sample_points(opts.sample) end
  local input_set = {}
  for _, n in ipairs(inputs) do input_set[n] = true end
  local sys, run = resolve(opts)
  if run == nil and opts.todo == nil then
    fail("no 'run': give run = function(sys, point) ... return {name = value, ...} end (or a 'file' that returns one)")
  end

  -- What is done already: the rows of out (resumed when its inputs are this
  -- sweep's), then those of 'from'.
  local done, writer = {}, nil
  if opts.out then
    local existing = opts.resume ~= false and read_results(opts.out) or nil
    if existing then
      local cols = existing.columns
      local same = not existing.bad and #cols >= #inputs + 1 and cols[#cols] == "error"
      for j, n in ipairs(inputs) do same = same and cols[j] == n end
      if not same then
        fail("'out' %s holds other results (columns: %s; this sweep's inputs: %s): choose another file, or resume = false to replace it",
          opts.out, existing.bad or table.concat(cols, ", "), table.concat(inputs, ", "))
      end
    end
    writer = Writer.new(opts.out, inputs, existing)
    for _, row in ipairs(writer.rows) do
      if not (opts.retry and row.error ~= nil) then done[point_key(inputs, row)] = row end
    end
  end

  local rows_by, queue, failed, computed = {}, {}, 0, 0
  local imported = opts.from and read_from(opts.from, inputs) or {}
  local function take(i, row)
    rows_by[i] = row
    if row.error ~= nil then failed = failed + 1 end
  end
  for i, p in ipairs(points) do
    local key = point_key(inputs, p)
    if done[key] then take(i, done[key])
    elseif imported[key] then
      local row = imported[key]
      done[key] = row
      if writer then writer:append(row) end
      take(i, row)
    else queue[#queue + 1] = i end
  end
  local nresumed = #points - #queue
  if nresumed > 0 and #queue > 0 and opts.out then
    io.stderr:write(("sweep: %s holds %d of the %d points; computing the %d missing\n"):format(
      opts.out, nresumed, #points, #queue))
  end

  if opts.todo then                  -- the points still to compute, for GNU parallel or a job array
    local f, err = io.open(opts.todo, "wb")
    if not f then fail("cannot write 'todo' (%s)", err) end
    for _, i in ipairs(queue) do f:write(M.record_line(inputs, points[i])) end
    f:close()
  else
    local ctx = { sys = sys, run = run, points = points, input_set = input_set }
    local jobs = math.min(opts.jobs or mech.sweep_ncpu(), math.max(#queue, 1))
    local update, done_bar = progress_bar(opts.progress, #queue)
    local saved = {}
    if sys and jobs == 1 then
      for _, n in ipairs(inputs) do if sys.params[n] ~= nil then saved[n] = sys.params[n] end end
    end
    local function finished(i, out, err)
      local row = {}
      for k, v in pairs(points[i]) do row[k] = v end
      if out then for k, v in pairs(out) do row[k] = v end else row.error = err end
      take(i, row)
      computed = computed + 1
      if writer then writer:append(row) end
      update(computed, failed)
    end
    local unanswered, how, code = 0, nil, nil
    local ok, err = pcall(function()
      if opts.parallel and #queue > 0 then unanswered, how, code = run_parallel(ctx, queue, finished, opts, inputs)
      elseif jobs == 1 then run_here(ctx, queue, finished)
      else run_forked(ctx, queue, jobs, finished, function() update(computed, failed) end) end
    end)
    done_bar()
    for n, v in pairs(saved) do sys.params[n] = v end
    if writer then writer:close() end
    if not ok and not rawequal(err, core.interrupted) then error(err, 0) end
    if not ok then
      local rows = { status = "interrupted", computed = computed, resumed = nresumed, failed = failed,
        missing = #points - nresumed - computed, columns = writer and writer:columns() }
      for i = 1, #points do if rows_by[i] then rows[#rows + 1] = rows_by[i] end end
      io.stderr:write(("sweep: stopped by Ctrl-C after %d of the %d points%s; %d missing\n"):format(
        nresumed + computed, #points, opts.out and (" (they are in %s: the same sweep again computes only the rest)"):format(opts.out) or "",
        rows.missing))
      return rows
    end
    if unanswered > 0 then
      local rows = { status = "incomplete", computed = computed, resumed = nresumed, failed = failed,
        missing = unanswered, columns = writer and writer:columns() }
      for i = 1, #points do if rows_by[i] then rows[#rows + 1] = rows_by[i] end end
      io.stderr:write(("sweep: GNU parallel (%s %s) gave no row for %d of the %d points%s\n"):format(
        how or "?", tostring(code), unanswered, #queue,
        opts.out and ("; they are not in %s: the same sweep again computes only them"):format(opts.out) or ""))
      return rows
    end
  end
  if writer then writer:close() end
  local rows = { status = opts.todo and "todo" or "complete", computed = computed, resumed = nresumed, failed = failed,
    todo = opts.todo and #queue or nil, columns = writer and writer:columns() or nil }
  for i = 1, #points do
    if rows_by[i] then rows[#rows + 1] = rows_by[i] end
  end
  return rows
end

----------------------------------------------------------------------------
-- nzlua --sweep-worker FILE: points on stdin, result rows on stdout

-- FILE returns {system = sys, run = function(sys, point) ... end} (the
-- worker has no other way to get run).  Each line of stdin is a point (name=value ...); each line of stdout
-- the point's inputs, its outputs and, when it failed, error="message", in
-- the same format, written as soon as the point is done.  Lines that are
-- not points are reported on stderr and the status is 1 at the end.
function M.worker(file, input, output)
  input, output = input or io.stdin, output or io.stdout
  local sys, run = load_file(file)
  if not run then
    error(("sweep worker: %s returns no run function: return {system = sys, run = function(sys, point) ... end}"):format(file), 0)
  end
  local bad, n = 0, 0
  for line in input:lines() do
    n = n + 1
    if line:match("%S") and not line:match("^%s*#") then
      local point, names = M.parse_record(line)
      if not point then
        bad = bad + 1
        io.stderr:write(("sweep worker: stdin:%d: %s: %s\n"):format(n, names, line))
      else
        local set = {}
        for _, k in ipairs(names) do set[k] = true end
        local out, err = evaluate(sys, run, point, set)
        local row, cols = {}, {}
        for _, k in ipairs(names) do row[k], cols[#cols + 1] = point[k], k end
        if out then
          for _, k in ipairs(sorted_keys(out)) do row[k], cols[#cols + 1] = out[k], k end
        else
          row.error, cols[#cols + 1] = err, "error"
        end
        output:write(M.record_line(cols, row))
        output:flush()
      end
    end
  end
  if bad > 0 then error(("sweep worker: %d line(s) of stdin were not points (name=value ...)"):format(bad), 0) end
end

return M

-- nz/plot.lua - line plots with gnuplot: in the terminal (gnuplot's dumb
-- terminal) or to an SVG or PNG file.  One function, used by trajectories
-- and the work-precision diagram.
local M = {}

M.INSTALL_HINT = "gnuplot is not installed: install it with 'sudo apt-get install gnuplot-nox' (or run 'make deps')"

-- An error about the caller's input, at the user's file:line: plot.lines is
-- called from the library (tr:plot, tr:section, ...), so error's levels
-- named lua/nz/trajectory.lua.
local function fail(msg) error(require("nz.where").user_where() .. msg, 0) end

local function have_gnuplot()
  local ok = os.execute("command -v gnuplot >/dev/null 2>&1")
  return ok == true or ok == 0
end

local function terminal_for(opts)
  local file = opts.file
  if not file then return ("dumb size %d,%d"):format(opts.width or 100, opts.height or 30) end
  local ext = file:match("%.(%w+)$")
  if ext == "svg" then return ("svg size %d,%d"):format(opts.width or 800, opts.height or 500) end
  if ext == "png" then return ("pngcairo size %d,%d"):format(opts.width or 800, opts.height or 500) end
  fail(("plot: file '%s' must end in .svg or .png"):format(file))
end

local function quote(s) return '"' .. tostring(s):gsub('"', "'") .. '"' end

-- Run gnuplot on a script (a list of lines): true and what it printed, or
-- false and its message.  (The terminal's plot is what it prints.)
function M.gnuplot(script)
  local sfile = os.tmpname()
  local sf = assert(io.open(sfile, "w"))
  sf:write(table.concat(script, "\n"), "\n")
  sf:close()
  local p = io.popen("gnuplot " .. sfile .. " 2>&1")
  local out = p:read("a")
  local ok = p:close()
  os.remove(sfile)
  return ok == true, out
end

-- plot.lines{ series = { {name =, x = {...}, y = {...} [, points = true, style =
--             "points", labels = {...} (a text beside each point)]}, ... },
--             title =, xlabel =, legend = false,
--             ylabel =, logx =, logy =, file = "out.svg", width =, height = }
-- Returns the text drawn (terminal) or the file name.
function M.lines(opts)
  if not have_gnuplot() then fail(M.INSTALL_HINT) end
  local series = opts.series
  if type(series) ~= "table" or #series == 0 then fail("plot: no series to draw") end
  local terminal = terminal_for(opts)     -- a bad file name is refused before any file is made
  local data = os.tmpname()
  local f = assert(io.open(data, "w"))
  local ylo, yhi = math.huge, -math.huge
  for si, s in ipairs(series) do
    if #s.x ~= #s.y then f:close(); os.remove(data); fail(("plot: series %d has %d x and %d y values"):format(si, #s.x, #s.y)) end
    for i = 1, #s.x do
      local x, y = s.x[i], s.y[i]
      if x == x and y == y and (not opts.logy or y > 0) and (not opts.logx or x > 0) then
        f:write(("%.17g %.17g %s\n"):format(x, y, s.labels and quote(s.labels[i] or "") or ""))
        ylo, yhi = math.min(ylo, y), math.max(yhi, y)
      end
    end
    f:write("\n\n")
  end
  f:close()
  -- A short terminal plot: gnuplot's own ticks would crowd into each other,
  -- so at most four, at a round step, with short labels.
  local yticks = ""
  if not opts.file and not opts.logy and (opts.height or 30) < 20 and yhi > ylo then
    local raw = (yhi - ylo) / 3
    local mag = 10 ^ math.floor(math.log(raw, 10))
    local step = mag * (raw / mag <= 1 and 1 or raw / mag <= 2 and 2 or raw / mag <= 5 and 5 or 10)
    yticks = ("set ytics %.17g\nset format y \"%%.3g\""):format(step)
  end
  local script = {
    "set terminal " .. terminal,
    opts.file and ("set output " .. quote(opts.file)) or "set output",
    opts.title and ("set title " .. quote(opts.title)) or "",
    opts.xlabel and ("set xlabel " .. quote(opts.xlabel)) or "",
    opts.ylabel and ("set ylabel " .. quote(opts.ylabel)) or "",
    opts.logx and 'set logscale x\nset format x "%.0e"' or "", opts.logy and 'set logscale y\nset format y "%.0e"' or "",
    yticks,
    opts.legend == false and "unset key" or "set key outside right", "set grid",
  }
  local parts = {}
  for si, s in ipairs(series) do
    parts[#parts + 1] = ("%s index %d using 1:2 with %s title %s"):format(quote(data), si - 1,
      s.style or (s.points and "linespoints" or "lines"), quote(s.name or ("series " .. si)))
    if s.labels then   -- a label beside each point (the work-precision diagram's tolerances)
      parts[#parts + 1] = ("%s index %d using 1:2:3 with labels left offset 0.6,0.3 font ',8' notitle"):format(quote(data), si - 1)
    end
  end
  script[#script + 1] = "plot " .. table.concat(parts, ", ")
  local ok, out = M.gnuplot(script)
  os.remove(data)
  if not ok then fail("plot: gnuplot failed: " .. out) end
  if opts.file then return opts.file end
  if not opts.quiet then io.write(out) end
  return out
end

return M

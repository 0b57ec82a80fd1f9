-- nz/draw/plot.lua - line plots with gnuplot: in the terminal (gnuplot's dumb
-- terminal) or to an SVG or PNG file.  One function, used by trajectories,
-- sections, eigenvalue sweeps and the work-precision diagram.
--
-- In the terminal every character counts, and gnuplot's own choices do not
-- fit it: its ticks follow the range, not the width (labels run together or
-- round to the same text), its autoscaled range ends on the data (a point
-- there lands on the frame and is drawn over), and its point labels cover
-- the marks and curves or get clipped.  So for the terminal the ranges,
-- the ticks and the point labels are chosen here, from the plot's size in
-- characters as gnuplot lays it out (measured by a first run).
local where = require "nz.base.where"
local frontend = require "nz.base.frontend"
local display = require "nz.draw.display"

local M = {}

M.INSTALL_HINT = "gnuplot is not installed: install it with 'sudo apt-get install gnuplot-nox' (or run 'make deps')"

-- An error about the caller's input: the user's file:line first.
local function fail(fmt, ...)
  error(where.user_where() .. "plot: " .. fmt:format(...), 0)
end

local function have_gnuplot()
  local ok = os.execute("command -v gnuplot >/dev/null 2>&1")
  return ok == true or ok == 0
end

local function terminal_for(opts)
  local file = opts.file
  if not file then return ("dumb size %d,%d"):format(opts.width or 100, opts.height or 30) end
  local ext = file:match("%.(%w+)$")
  if ext == "svg" then return ("svg size %d,%d"):format(opts.width or 800, opts.height or 500) end
  return ("pngcairo size %d,%d"):format(opts.width or 800, opts.height or 500)
end

local function quote(s) return '"' .. tostring(s):gsub('"', "'") .. '"' end

-- The colours of the series in an SVG or PNG, in order (gnuplot's own
-- fifth and fourth, yellow #F0E442 and orange #E69F00, have a contrast of
-- 1.3 and 2.2 against white, where figures need 3): each at least 4.6
-- (WCAG 2's contrast ratio), distinct in hue, and every series has a point
-- type of its own besides (the work-precision diagram, the terminal).
M.COLOURS = { "#9400D3", "#007A5E", "#0072B2", "#C44E00", "#882255", "#000000", "#E51E10", "#8B4513", "#AA4499",
  "#332288", "#666666", "#117733" }

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

-- The options every plot takes, checked before gnuplot runs.  Sizes are in
-- characters for the terminal, in pixels for a file; below these minimums
-- there is no room for the frame, the ticks and the key.
local MIN_TERMINAL, MIN_FILE = { 30, 10 }, { 100, 100 }
local function check_common(opts)
  local file = opts.file
  if file ~= nil then
    if type(file) ~= "string" then fail("file must be a file name ending in .svg or .png, got %s", type(file)) end
    local ext = file:match("%.(%w+)$")
    if ext ~= "svg" and ext ~= "png" then
      fail("file '%s' must end in .svg or .png (or leave file out to draw in the terminal)", file)
    end
  end
  local min = file and MIN_FILE or MIN_TERMINAL
  for i, key in ipairs{ "width", "height" } do
    local v = opts[key]
    local whole = type(v) == "number" and v == math.floor(v)
    if v ~= nil and (not whole or v < min[i] or v > 10000) then
      fail("%s = %s: a whole number from %d to 10000 expected (%s, %s)", key,
        require("nz.base.text").literal(v), min[i],
        file and "pixels of the file" or "characters of the terminal", key == "width" and "columns" or "lines")
    end
  end
end

-- Ticks -----------------------------------------------------------------

-- The label of tick k * step, step = m * 10^e: as many decimals as the step
-- has, so that neighbouring labels always differ (0.08 0.10 0.12, never
-- 0.1 0.1); very large or small values in exponent form, with as many
-- digits as tell them apart.
local function tick_label(v, e, biggest)
  if v == 0 then return "0" end
  if biggest >= 1e6 or biggest < 1e-3 then
    return ("%." .. math.max(0, math.floor(math.log(biggest, 10) + 1e-9) - e) .. "e"):format(v)
  end
  return ("%." .. math.max(0, -e) .. "f"):format(v)
end

-- Whether ticks (a list of {pos, label} with pos along an axis showing
-- [lo, hi] over `cells` characters) are at least room(w, cells) characters
-- apart, w the widest label.
local function fits(ticks, lo, hi, cells, room)
  if #ticks <= 1 then return true end
  local w = 0
  for _, t in ipairs(ticks) do w = math.max(w, #t.label) end
  for i = 2, #ticks do
    if (ticks[i].pos - ticks[i - 1].pos) / (hi - lo) * cells < room(w, cells) then return false end
  end
  return true
end

-- The finest round step (1, 2 or 5 times a power of ten) whose ticks fit.
local function linear_ticks(lo, hi, cells, room)
  for e = math.floor(math.log(hi - lo, 10)) - 2, 400 do
    for _, m in ipairs{ 1, 2, 5 } do
      local step = m * 10.0 ^ e
      local k0, k1 = math.ceil(lo / step), math.floor(hi / step)
      local biggest = math.max(math.abs(k0 * step), math.abs(k1 * step))
      local ticks = {}
      for k = k0, k1 do ticks[#ticks + 1] = { pos = k * step, label = tick_label(k * step, e, biggest) } end
      if fits(ticks, lo, hi, cells, room) then return ticks end
    end
  end
  return {}
end

-- On a log axis (lo, hi are log10 of the range): 1, 2 and 5 in each decade,
-- else every decade, every second, fifth, tenth ... that fits.
local function log_ticks(lo, hi, cells, room)
  local ticks = {}
  for j = math.floor(lo), math.ceil(hi) do
    for _, m in ipairs{ 1, 2, 5 } do
      local pos = j + math.log(m, 10)
      if pos >= lo - 1e-9 and pos <= hi + 1e-9 then ticks[#ticks + 1] = { pos = pos, label = ("%.0e"):format(m * 10.0 ^ j) } end
    end
  end
  if fits(ticks, lo, hi, cells, room) then return ticks end
  for _, n in ipairs{ 1, 2, 5, 10, 20, 50, 100 } do
    ticks = {}
    for j = math.ceil(lo / n) * n, math.floor(hi / n) * n, n do ticks[#ticks + 1] = { pos = j, label = ("%.0e"):format(10.0 ^ j) } end
    if fits(ticks, lo, hi, cells, room) then return ticks end
  end
  return {}
end

-- The range an axis of `cells` characters shows for data in [lo, hi] (log10
-- on a log axis), with `pad` characters more at each end (`pad_hi` at the
-- high end when given), so that a point on the edge of the data is drawn
-- inside the frame and clear of its tick marks, not over them.  The tick
-- marks take the two columns inside each side of the frame ("|-+", "+-|")
-- and the line inside its top and bottom: PAD_X and PAD_Y clear them by a
-- quarter of a character.
-- A small plot (an axis under SMALL_X columns or SMALL_Y lines) cannot
-- spare that much room from its ticks: there each end gets the character
-- and a quarter that keeps a point off the frame itself.  pad_hi (room for
-- the labels of the last points) is at most a sixth of the axis more.
local PAD_X, PAD_Y, PAD_MIN = 3.25, 2.25, 1.25
local SMALL_X, SMALL_Y = 32, 12
local function padded(lo, hi, cells, log, pad, pad_hi)
  local extra = pad_hi and math.min(pad_hi - pad, cells / 6) or 0
  if cells < (pad == PAD_X and SMALL_X or SMALL_Y) then pad = PAD_MIN end
  pad_hi = pad + extra
  if hi <= lo then
    local d = log and 0.5 or (lo ~= 0 and math.abs(lo) * 0.1 or 1)
    lo, hi = lo - d, hi + d
  end
  local room = cells - pad - pad_hi
  if room < 2 then pad, pad_hi, room = 0.2 * cells, 0.2 * cells, 0.6 * cells end
  local per_cell = (hi - lo) / room
  return lo - pad * per_cell, hi + pad_hi * per_cell
end

-- The set-commands of an axis ("x" or "y") in the terminal, and the widest
-- tick label: the range and the ticks with their labels.
local function axis(name, lo, hi, cells, log, room, pad, pad_hi)
  lo, hi = padded(lo, hi, cells, log, pad, pad_hi)
  local ticks = (log and log_ticks or linear_ticks)(lo, hi, cells, room)
  local items, w = {}, 0
  for i, t in ipairs(ticks) do
    items[i] = ("%s %.17g"):format(quote(t.label), log and 10 ^ t.pos or t.pos)
    w = math.max(w, #t.label)
  end
  local r = log and { 10 ^ lo, 10 ^ hi } or { lo, hi }
  -- no tick fits: none (gnuplot's own would run together)
  return { ("set %srange [%.17g:%.17g]"):format(name, r[1], r[2]),
    #items > 0 and ("set %stics (%s)"):format(name, table.concat(items, ", ")) or ("unset %stics"):format(name) },
    w, lo, hi
end

-- Tick labels across: at least two blanks between neighbours (the widest
-- label plus 2 from centre to centre, labels being centred on their ticks)
-- and not closer than 5.  Up the side: a blank line between, unless the
-- frame is under 10 lines high (then each on a line of its own).
local function x_room(w) return math.max(w + 2, 5) end
local function y_room(_, cells) return cells >= 10 and 2 or 1 end

-- Point labels in the terminal --------------------------------------------

-- A label in lines of at most n characters (broken at blanks where it can),
-- and the longest line's length as .width.
local function wrap(text, n)
  local lines, cur = {}, ""
  for word in text:gmatch("%S+") do
    while #word > n do          -- a word longer than a line: cut it
      if cur ~= "" then lines[#lines + 1] = cur; cur = "" end
      lines[#lines + 1] = word:sub(1, n)
      word = word:sub(n + 1)
    end
    if cur == "" then cur = word
    elseif #cur + 1 + #word <= n then cur = cur .. " " .. word
    else lines[#lines + 1] = cur; cur = word end
  end
  if cur ~= "" then lines[#lines + 1] = cur end
  lines.width = 0
  for _, l in ipairs(lines) do lines.width = math.max(lines.width, #l) end
  return lines
end

-- The characters a label may cover: blanks and the grid's dots.
local FREE = { [" "] = true, ["."] = true, [":"] = true }

-- Write each series' point labels into the terminal's text beside their
-- points, where the label and a blank around it cover nothing drawn and
-- stay inside the frame: right of the point, left, or the line above or
-- below.  A label with no such place is left out (the caller's table gives
-- every value; a label over a curve or cut by the frame misleads).
-- g: the frame in characters (x0, x1 columns, y0, y1 lines from the bottom),
-- the axes' ranges (log10 on log axes).
local function place_labels(text, series, drawn, g, opts, ylabel)
  -- the page starts at the form feed (a warning of gnuplot's may come first)
  local start = text:find("\f", 1, true) or 1
  local rows = {}
  for line in (text:sub(start) .. "\n"):gmatch("([^\n]*)\n") do rows[#rows + 1] = line end
  local height = opts.height or 30
  local function free(r, c1, c2)
    if r < height - g.y1 + 1 or r > height - g.y0 - 1 or c1 < g.x0 + 1 or c2 > g.x1 - 1 then return false end
    for c = c1, c2 do
      if not FREE[rows[r]:sub(c + 1, c + 1)] then return false end
    end
    return true
  end
  local function cell(v, lo, hi, a, b, log)
    if log then v = math.log(v, 10) end
    return math.floor(a + (v - lo) / (hi - lo) * (b - a) + 0.5)
  end
  if ylabel then       -- the y label at the left, across the middle of the frame
    local top = height - (g.y0 + g.y1) // 2 - (#ylabel - 1) // 2
    for k, text_line in ipairs(ylabel) do
      local r = math.max(1, math.min(height, top + k - 1))
      rows[r] = text_line .. rows[r]:sub(#text_line + 1)
    end
  end
  for si, s in ipairs(series) do
    if s.labels then
      for i = 1, #s.x do
        local x, y, label = s.x[i], s.y[i], s.labels[i]
        if label and label ~= "" and drawn[si][i] then
          local c = cell(x, g.xlo, g.xhi, g.x0, g.x1, opts.logx)
          local r = height - cell(y, g.ylo, g.yhi, g.y0, g.y1, opts.logy)
          local n, half = #label, #label // 2
          -- (line, first column) of each place, the blank around included
          for _, p in ipairs{ { r, c + 2 }, { r, c - n - 1 }, { r - 1, c + 1 }, { r - 1, c - n }, { r + 1, c + 1 },
              { r + 1, c - n }, { r - 1, c - half }, { r + 1, c - half } } do
            if free(p[1], p[2] - 1, p[2] + n) then
              local line = rows[p[1]]
              rows[p[1]] = line:sub(1, p[2]) .. label .. line:sub(p[2] + n + 1)
              break
            end
          end
        end
      end
    end
  end
  return text:sub(1, start - 1) .. table.concat(rows, "\n", 1, height) .. "\n"
end

-- A picture for a notebook: draw(o) draws into a temporary file of the
-- given extension, o being opts with file, width and height set (width and
-- height in the terminal's characters, PX_PER_COLUMN x PX_PER_LINE pixels
-- each: 100 x 30, the terminal's default, is 800 x 480; nil keeps the
-- drawing's own size). Returns the file's bytes; the temporary files are
-- removed whatever happens and draw's error is raised again.
local PX_PER_COLUMN, PX_PER_LINE = 8, 16
function M.drawn(ext, draw, opts, width, height)
  local tmp = os.tmpname()
  local file = tmp .. "." .. ext
  local o = setmetatable({ file = file, width = width and width * PX_PER_COLUMN, height = height and height * PX_PER_LINE },
    { __index = opts })
  local ok, err = pcall(draw, o)
  local f = io.open(file, "rb")
  local bytes = f and f:read("a")
  if f then f:close() end
  os.remove(file)
  os.remove(tmp)
  if not ok then error(err, 0) end
  return bytes
end

-- A notebook's plot: gnuplot's SVG of the same plot, sized from the
-- terminal's characters, as an <img> in HTML, with a PNG of it (another
-- gnuplot run, pngcairo at the same size) and a line of text beside it,
-- each made only if the front-end takes it (nz/draw/display.lua).  Not as
-- image/svg+xml: nbconvert's LaTeX, the road to a PDF, converts every SVG
-- with Inkscape before it looks for a PNG, and fails where Inkscape is not.
function M.inline(opts)
  local width, height = opts.width or 100, opts.height or 30
  local names = {}
  for i, s in ipairs(opts.series) do names[i] = s.name or ("series " .. i) end
  local text = ("plot%s: %s"):format(opts.title and (" '" .. opts.title .. "'") or "", table.concat(names, ", "))
  display.show(display.bundle{
    ["text/html"] = function()
      local svg = M.drawn("svg", M.lines, opts, width, height)
      return svg and display.img("image/svg+xml", svg, text)
    end,
    ["image/png"] = function() return M.drawn("png", M.lines, opts, width, height) end,
    ["text/plain"] = text,
  })
end

-- Whether the key goes under the axes: in the terminal, when a series'
-- name is longer than a quarter of the width (at the right, such a key
-- leaves the curves a fifth of the columns: nz.longrun's "rk4 step 0.0157,
-- energy (slope 0.98)").  Files keep it at the right (800 pixels wide).
local function key_below(opts)
  if opts.file then return false end
  for _, s in ipairs(opts.series) do
    if #tostring(s.name or "") > (opts.width or 100) / 4 then return true end
  end
  return false
end

-- plot.lines{ series = { {name =, x = {...}, y = {...} [, points = true, style =
--             "points", labels = {...} (a text beside each point)]}, ... },
--             title =, xlabel =, legend = false,
--             ylabel =, logx =, logy =, file = "out.svg", width =, height = }
-- Returns the text drawn (terminal) or the file name.  Values that are NaN
-- or infinite (or not positive on a log axis) are left out.
function M.lines(opts)
  if not have_gnuplot() then error(where.user_where() .. M.INSTALL_HINT, 0) end
  local series = opts.series
  if type(series) ~= "table" or #series == 0 then fail("no series to draw") end
  check_common(opts)
  if not opts.file and not opts.quiet and (frontend.accepts("text/html") or frontend.accepts("image/png")) then
    return M.inline(opts)
  end
  local data = os.tmpname()
  local f = assert(io.open(data, "w"))
  local xlo, xhi, ylo, yhi = math.huge, -math.huge, math.huge, -math.huge
  local drawn = {}   -- drawn[si][i]: whether the point is in the data file
  local function drawable(v, log) return type(v) == "number" and v == v and math.abs(v) < math.huge and (not log or v > 0) end
  for si, s in ipairs(series) do
    local bad = (type(s.x) ~= "table" or type(s.y) ~= "table") and ("series %d: lists x = {...} and y = {...} expected"):format(si)
      or #s.x ~= #s.y and ("series %d has %d x and %d y values"):format(si, #s.x, #s.y)
    if bad then f:close(); os.remove(data); fail("%s", bad) end   -- no temporary file left behind
    drawn[si] = {}
    for i = 1, #s.x do
      local x, y = s.x[i], s.y[i]
      if drawable(x, opts.logx) and drawable(y, opts.logy) then
        f:write(("%.17g %.17g %s\n"):format(x, y, s.labels and quote(s.labels[i] or "") or ""))
        xlo, xhi, ylo, yhi = math.min(xlo, x), math.max(xhi, x), math.min(ylo, y), math.max(yhi, y)
        drawn[si][i] = true
      end
    end
    f:write("\n\n")
  end
  f:close()
  if xlo > xhi then
    os.remove(data)
    fail("nothing to draw: every value is NaN or infinite%s", (opts.logx or opts.logy) and " or not positive on a log axis" or "")
  end
  local terminal = not opts.file
  local ylabel = terminal and opts.ylabel and wrap(tostring(opts.ylabel), math.max(10, (opts.width or 100) // 7))
  if ylabel and #ylabel == 0 then ylabel = nil end
  local script = {
    "set terminal " .. terminal_for(opts),
    terminal and "set output" or ("set output " .. quote(opts.file)),
    opts.title and ("set title " .. quote(opts.title)) or "",
    opts.xlabel and ("set xlabel " .. quote(opts.xlabel)) or "",
    -- (the terminal's y label is written in below: gnuplot counts it one
    -- character wide, as if turned, and lets it run over the tick labels)
    opts.ylabel and not terminal and ("set ylabel " .. quote(opts.ylabel)) or "",
    opts.logx and 'set logscale x\nset format x "%.0e"' or "", opts.logy and 'set logscale y\nset format y "%.0e"' or "",
    opts.legend == false and "unset key" or key_below(opts) and "set key below" or "set key outside right", "set grid",
  }

  local parts = {}
  for si, s in ipairs(series) do
    local style = s.style or (s.points and "linespoints" or "lines")
    -- in a file, series si takes colour si, its labels too
    local colour = M.COLOURS[(si - 1) % #M.COLOURS + 1]
    if not terminal and not style:find("lc ") and not style:find("linecolor") then
      style = ("%s lc rgb %q"):format(style, colour)
    end
    parts[#parts + 1] = ("%s index %d using 1:2 with %s title %s"):format(quote(data), si - 1, style,
      quote(s.name or ("series " .. si)))
    if s.labels and not terminal then   -- a label beside each point (the work-precision diagram's tolerances)
      parts[#parts + 1] = ("%s index %d using 1:2:3 with labels left offset 0.6,0.3 font ',8' textcolor rgb %q notitle")
        :format(quote(data), si - 1, colour)
    end
  end
  if terminal then
    -- the marks once more, over every curve: a later series' line would
    -- cover an earlier one's points (the marks tell the series apart)
    for si, s in ipairs(series) do
      local style = s.style or (s.points and "linespoints" or "lines")
      if style:match("^linespoints") then
        parts[#parts + 1] = ("%s index %d using 1:2 with points pt %s notitle"):format(quote(data), si - 1,
          style:match("pt (%d+)") or tostring(si))
      end
    end
  end
  local plot_line = "plot " .. table.concat(parts, ", ")
  local geometry
  if terminal then
    -- the frame in characters: a first run with the y tick labels left
    -- out (they widen the left margin by their width, added below)
    local measure = { table.unpack(script) }
    local gfile = os.tmpname()
    measure[2] = 'set output "/dev/null"'
    measure[#measure + 1] = 'set format y ""'
    measure[#measure + 1] = plot_line
    measure[#measure + 1] = ("set print %s\nprint GPVAL_TERM_XMIN, GPVAL_TERM_XMAX, GPVAL_TERM_YMIN, GPVAL_TERM_YMAX"):format(quote(gfile))
    local ok, out = M.gnuplot(measure)
    local gf = io.open(gfile)
    local g = gf and gf:read("a") or ""
    if gf then gf:close() end
    os.remove(gfile)
    if not ok then os.remove(data); fail("gnuplot failed: %s", out) end
    local x0, x1, y0, y1 = g:match("([%d.-]+)%s+([%d.-]+)%s+([%d.-]+)%s+([%d.-]+)")
    x0, x1, y0, y1 = tonumber(x0), tonumber(x1), tonumber(y0), tonumber(y1)
    if not (x0 and x1 and y0 and y1) then os.remove(data); fail("gnuplot did not report the plot's frame: %s", out) end
    local function ends(lo, hi, log) if log then return math.log(lo, 10), math.log(hi, 10) end return lo, hi end
    local ya, yb = ends(ylo, yhi, opts.logy)
    local xa, xb = ends(xlo, xhi, opts.logx)
    local yset, w
    yset, w, ya, yb = axis("y", ya, yb, y1 - y0, opts.logy, y_room, PAD_Y)
    -- labelled points: room on the right for the labels of the last ones
    local widest = 0
    for _, s in ipairs(series) do
      for _, l in ipairs(s.labels or {}) do widest = math.max(widest, #l) end
    end
    local xset, _
    xset, _, xa, xb = axis("x", xa, xb, x1 - x0 - w - (ylabel and ylabel.width or 0), opts.logx, x_room, PAD_X,
      widest > 0 and PAD_X + widest + 1 or nil)
    -- the left margin set: the y label's lines, then (as measured) a
    -- blank, the tick labels, a blank
    x0 = x0 + w + (ylabel and ylabel.width or 0)
    script[#script + 1] = ("set lmargin %d"):format(x0)
    geometry = { x0 = x0, x1 = x1, y0 = y0, y1 = y1, xlo = xa, xhi = xb, ylo = ya, yhi = yb }
    for _, l in ipairs(xset) do script[#script + 1] = l end
    for _, l in ipairs(yset) do script[#script + 1] = l end
  end
  script[#script + 1] = plot_line
  local ok, out = M.gnuplot(script)
  os.remove(data)
  if not ok then fail("gnuplot failed: %s", out) end
  if opts.file then return opts.file end
  out = place_labels(out, series, drawn, geometry, opts, ylabel)
  if not opts.quiet then io.write(out) end
  return out
end

return M

-- nz/base/text.lua - the text every part of nz writes the same way: a number in
-- the shortest digits that read back exactly, an aligned table, words
-- wrapped to the terminal's width.  Below
-- every other module (it requires none): systems, analyses, plots and the
-- session all use it, and a front-end that shows tables as HTML watches
-- them being made (M.on_table) rather than parsing the text back.
local M = {}

-- A float as the shortest decimal that reads back exactly (%.15g, %.16g
-- or %.17g: math.pi is 3.141592653589793), keeping Lua's ".0" mark of an
-- integral float.
function M.number(v)
  if math.type(v) == "integer" then return tostring(v) end
  -- the C library says "nan", "-nan" or "inf": the same words everywhere
  if v ~= v then return "NaN" end
  if math.abs(v) == math.huge then return v > 0 and "inf" or "-inf" end
  local s
  for digits = 15, 17 do
    s = ("%." .. digits .. "g"):format(v)
    if tonumber(s) == v then break end
  end
  if s:match("^%-?%d+$") then s = s .. ".0" end
  return s
end

-- Called as M.on_table(text, rows) with every table made, when set: the
-- notebook's front-end keeps the rows to show the table as HTML beside its
-- text (nz/draw/display.lua).  The terminal sets nothing and pays nothing.
M.on_table = nil

-- A value as Lua would write it, for a message in the form `key = value`:
-- a string quoted ("xy"), a number in its shortest exact digits, anything
-- else by tostring.  (After "got", base/args.lua's shown says more.)
function M.literal(v)
  if type(v) == "string" then return ("%q"):format(v) end
  if type(v) == "number" then return M.number(v) end
  return tostring(v)
end

-- A list of numbers as "{a, b, c}", each written by fmt: a function, a
-- format ("%.6g", as messages give a state) or by default M.number, the
-- shortest digits that read back exactly.
function M.list(v, fmt)
  fmt = fmt or M.number
  local p = {}
  for i = 1, #v do p[i] = type(fmt) == "string" and fmt:format(v[i]) or fmt(v[i]) end
  return "{" .. table.concat(p, ", ") .. "}"
end

-- Aligned table of rows of strings; the first row is the header, ruled
-- below; the first column left-aligned, the others right-aligned.
function M.table(rows, indent)
  local widths = {}
  for _, row in ipairs(rows) do
    for c, cell in ipairs(row) do widths[c] = math.max(widths[c] or 0, #cell) end
  end
  local out = {}
  for r, row in ipairs(rows) do
    local cells = {}
    for c, cell in ipairs(row) do
      cells[c] = c == 1 and cell .. (" "):rep(widths[c] - #cell) or (" "):rep(widths[c] - #cell) .. cell
    end
    out[#out + 1] = (indent or "  ") .. table.concat(cells, "   ")
    if r == 1 then
      local rule = {}
      for c = 1, #row do rule[c] = ("-"):rep(widths[c]) end
      out[#out + 1] = (indent or "  ") .. table.concat(rule, "   ")
    end
  end
  local text = table.concat(out, "\n")
  if M.on_table then M.on_table(text, rows) end
  return text
end

-- Text is read in a terminal: help, tables and reports fit in WIDTH
-- columns (tests/help_spec.lua checks every help line).
M.WIDTH = 80

local function width(s) return utf8.len(s) or #s end

-- The words of `text` in lines of at most M.WIDTH columns, the first line
-- starting with `first`, the others with `rest`.
function M.wrap(text, first, rest)
  local lines, line, empty = {}, first, true
  for word in text:gmatch("%S+") do
    if not empty and width(line) + 1 + width(word) > M.WIDTH then
      lines[#lines + 1] = line
      line = rest .. word
    else
      line = line .. (empty and "" or " ") .. word
    end
    empty = false
  end
  lines[#lines + 1] = line
  return table.concat(lines, "\n")
end

return M

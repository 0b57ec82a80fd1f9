-- nz/draw/display.lua - one display layer for every front-end.  A value to show
-- becomes a bundle of representations keyed by MIME type (text/plain,
-- text/latex, text/html, image/svg+xml, image/png, image/gif), each built only when a
-- front-end asks for it: the terminal takes the text, a notebook everything
-- it renders (nz/base/frontend.lua says which front-end is in use).  So the
-- terminal never pays for the LaTeX, HTML or SVG it would not show.
--
-- Where the representations come from:
--   text/plain  the session's picture of a value (M.format), for everything;
--   text/html   the tables in that text (nz/base/text.lua's M.table), as <table>s,
--               when the front-end keeps them (M.keep_tables);
--   others      offered by the code that made the value (M.offer: sys:show's
--               LaTeX) or published directly (a plot's SVG, an animation's
--               GIF: M.show with a bundle).
--
-- A picture goes as an <img> in text/html (an SVG or GIF inside) and as a
-- PNG, so that it survives a notebook's export: nbconvert's HTML takes
-- text/html first and blanks an SVG put inline (its cleaner strips the
-- SVG's attributes, nbconvert issue 1894), and its LaTeX (the road to a
-- PDF) takes a PNG.
local text = require "nz.base.text"
local frontend = require "nz.base.frontend"

local M = {}

-- The types a bundle can hold, in the order a front-end receives them.
M.MIMES = { "text/plain", "text/latex", "text/html", "image/svg+xml", "image/png", "image/gif" }

M.number = text.number

-- The session's one-line picture of a value --------------------------------

local MAX_ITEMS = 12

local function is_identifier(s)
  return type(s) == "string" and s:match("^[%a_][%w_]*$") ~= nil
end

-- A short one-line picture of a value; tables show their first few entries.
local function format(v, depth)
  local t = type(v)
  if t == "string" then return depth > 0 and ("%q"):format(v) or v end
  if t == "number" then return text.number(v) end
  if t ~= "table" or getmetatable(v) and getmetatable(v).__tostring then return tostring(v) end
  if depth >= 2 then return "{...}" end
  local parts, n = {}, #v
  for i = 1, math.min(n, MAX_ITEMS) do parts[#parts + 1] = format(v[i], depth + 1) end
  local keys = {}
  for k in pairs(v) do
    if not (math.type(k) == "integer" and k >= 1 and k <= n) then keys[#keys + 1] = k end
  end
  table.sort(keys, function(a, b) return tostring(a) < tostring(b) end)
  for _, k in ipairs(keys) do
    if #parts >= MAX_ITEMS then parts[#parts + 1] = "..."; break end
    local key = is_identifier(k) and k or ("[" .. format(k, depth + 1) .. "]")
    parts[#parts + 1] = key .. " = " .. format(v[k], depth + 1)
  end
  return "{" .. table.concat(parts, ", ") .. "}"
end

-- nz.format(v): a value as the session shows it.
function M.format(v) return format(v, 0) end

-- Several values as the session prints them: tab-separated.
function M.format_values(...)
  local parts = {}
  for i = 1, select("#", ...) do parts[i] = format((select(i, ...)), 0) end
  return table.concat(parts, "\t")
end

-- Bundles -------------------------------------------------------------------

local Bundle = {}
Bundle.__index = Bundle

-- A bundle from a table MIME type -> string, or function returning the
-- string (or nil: no such representation after all), called at most once.
function M.bundle(reps)
  return setmetatable({ reps = reps, built = {} }, Bundle)
end

function Bundle:get(mime)
  local v = self.built[mime]
  if v == nil then
    v = self.reps[mime]
    if type(v) == "function" then v = v() end
    self.built[mime] = v or false
  end
  return v or nil
end

function Bundle:add(mime, rep)
  if self.reps[mime] == nil then self.reps[mime] = rep end
  return self
end

-- The representations a front-end renders, built now: MIME type -> string.
function Bundle:data(accepts)
  local out = {}
  for _, mime in ipairs(M.MIMES) do
    if accepts[mime] and self.reps[mime] ~= nil then out[mime] = self:get(mime) end
  end
  return out
end

-- Show a bundle on the front-end in use (kind: "display" or "result").
function M.show(bundle, kind)
  local fe = frontend.current()
  fe.publish(bundle:data(fe.accepts), kind or "display")
end

-- Representations offered with a value ------------------------------------

-- A string made by a function that knows more ways to show it (sys:show's
-- equations as LaTeX) is offered with them: the next bundle of that same
-- string has them.  Only when the front-end renders one of them (the
-- terminal stores nothing), and only the last few strings (a session
-- that shows many keeps no memory of the old ones).
local OFFERS_KEPT = 16
local offers, offer_order = {}, {}

function M.offer(s, reps)
  local wanted = false
  for mime in pairs(reps) do wanted = wanted or frontend.accepts(mime) end
  if not wanted then return s end
  if not offers[s] then
    offer_order[#offer_order + 1] = s
    if #offer_order > OFFERS_KEPT then offers[table.remove(offer_order, 1)] = nil end
  end
  offers[s] = reps
  return s
end

-- Tables as HTML ------------------------------------------------------------

-- The tables made lately (text and rows), newest last: a value's text is
-- searched for them.  Kept only while a front-end that renders HTML asks
-- (M.keep_tables(true)); a value typed again later makes its tables again
-- as its text is made, so the few kept suffice.
local TABLES_KEPT = 64
local tables = {}

local function keep(s, rows)
  for i = #tables, 1, -1 do
    if tables[i].text == s then table.remove(tables, i) end
  end
  tables[#tables + 1] = { text = s, rows = rows }
  if #tables > TABLES_KEPT then table.remove(tables, 1) end
end

function M.keep_tables(on)
  text.on_table = on and keep or nil
  if not on then tables = {} end
end

local ESCAPES = { ["&"] = "&amp;", ["<"] = "&lt;", [">"] = "&gt;", ['"'] = "&quot;" }
function M.escape(s) return (s:gsub('[&<>"]', ESCAPES)) end

local function html_table(rows)
  local out = { '<table class="nzlua">' }
  for r, row in ipairs(rows) do
    local cells = {}
    for c, cell in ipairs(row) do
      local tag = r == 1 and "th" or "td"
      -- as in the text: the first column to the left, the numbers to the right
      cells[c] = ('<%s style="text-align:%s">%s</%s>'):format(tag, c == 1 and "left" or "right", M.escape(cell), tag)
    end
    out[#out + 1] = (r == 1 and "<thead>" or "") .. "<tr>" .. table.concat(cells) .. "</tr>" .. (r == 1 and "</thead><tbody>" or "")
  end
  out[#out + 1] = "</tbody></table>"
  return table.concat(out)
end

-- A text with tables in it as HTML: each table whose text it holds as a
-- <table>, the lines around them as preformatted text.  nil when it holds
-- no table (its text is all there is to show).
function M.html(s)
  -- a table is two lines at least (its header and its rule): one line has none
  if type(s) ~= "string" or not s:find("\n", 1, true) or #tables == 0 then return nil end
  local found = {}
  for i = #tables, 1, -1 do
    local t = tables[i]
    local a, b = s:find(t.text, 1, true)
    if a then found[#found + 1] = { a = a, b = b, rows = t.rows } end
  end
  if #found == 0 then return nil end
  table.sort(found, function(x, y) return x.a < y.a end)
  local out, at = { '<div class="nzlua-text">' }, 1
  local function pre(from, to)
    local piece = s:sub(from, to):gsub("^\n", ""):gsub("\n$", "")
    if piece:find("%S") then out[#out + 1] = "<pre>" .. M.escape(piece) .. "</pre>" end
  end
  for _, f in ipairs(found) do
    if f.a >= at then
      pre(at, f.a - 1)
      out[#out + 1] = html_table(f.rows)
      at = f.b + 1
    end
  end
  pre(at, #s)
  out[#out + 1] = "</div>"
  return table.concat(out, "\n")
end

-- LaTeX for a notebook ------------------------------------------------------

-- sys:show{tex = true}'s LaTeX (aligned blocks, each extra one named in a
-- "% title" comment line) as a notebook's MathJax typesets it: each block
-- in display math, each title as a line of text.
function M.latex(tex)
  local out = {}
  for line in (tex .. "\n"):gmatch("([^\n]*)\n") do
    local title = line:match("^%% (.*)$")
    if title then
      out[#out + 1] = title .. ":"
    elseif line == "\\begin{aligned}" then
      out[#out + 1] = "$$\\begin{aligned}"
    elseif line == "\\end{aligned}" then
      out[#out + 1] = "\\end{aligned}$$"
    else
      out[#out + 1] = line
    end
  end
  return table.concat(out, "\n")
end

-- An image as HTML, its bytes inside (a data URI: the notebook and its
-- exported page need no file beside them).
function M.img(mime, bytes, alt)
  return ('<img src="data:%s;base64,%s" alt="%s"/>'):format(mime, M.base64(bytes), M.escape(alt))
end

-- Base64 (RFC 4648), for an image inside HTML.
local B64 = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/"
function M.base64(s)
  local out = {}
  for i = 1, #s, 3 do
    local a, b, c = s:byte(i, i + 2)
    local n = a * 65536 + (b or 0) * 256 + (c or 0)
    local d = { n >> 18, (n >> 12) & 63, (n >> 6) & 63, n & 63 }
    out[#out + 1] = B64:sub(d[1] + 1, d[1] + 1) .. B64:sub(d[2] + 1, d[2] + 1)
      .. (b and B64:sub(d[3] + 1, d[3] + 1) or "=") .. (c and B64:sub(d[4] + 1, d[4] + 1) or "=")
  end
  return table.concat(out)
end

-- The bundle of a value ----------------------------------------------------

-- Every representation of v the display layer knows: its text, the HTML
-- of the tables in it, and what was offered with it.  Nothing is built
-- until a front-end asks.
function M.of(v)
  local b = M.bundle{ ["text/plain"] = function() return format(v, 0) end }
  -- (the terminal's bundle holds its text alone: nothing else is even set up)
  if frontend.accepts("text/html") then b.reps["text/html"] = function() return M.html(b:get("text/plain")) end end
  local extra = type(v) == "string" and offers[v]
  if extra then
    for mime, rep in pairs(extra) do b.reps[mime] = rep end
  end
  return b
end

-- The bundle of several values printed together: one value has all its
-- representations, several their text, tab-separated (as print does).
function M.of_values(...)
  if select("#", ...) == 1 then return M.of((...)) end
  local values = table.pack(...)
  return M.bundle{ ["text/plain"] = function() return M.format_values(table.unpack(values, 1, values.n)) end }
end

-- nz.print(...): values shown as the session shows them, from a script or
-- a cell (in a notebook with their tables as HTML).
function M.print(...)
  if frontend.current() == frontend.terminal then
    print(M.format_values(...))        -- the terminal: exactly print's output, nothing built besides
    return
  end
  M.show(M.of_values(...))
end

return M

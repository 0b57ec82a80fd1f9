-- nz/base/frontend.lua - which front-end shows what nzlua prints: the terminal
-- (the session, a script: the default) or a Jupyter notebook (nz/session/kernel.lua
-- installs its own with M.use).  Below every other module, so that any of
-- them can ask what the person will see (a plot as SVG or as characters?
-- a progress bar?) without requiring the modules that build what is shown
-- (nz/draw/display.lua) or the front-ends themselves (the session's floor).
--
-- A front-end is a table:
--   name      "terminal", "jupyter"
--   accepts   the set of MIME types it renders: {["text/plain"] = true, ...}
--   publish   function(data, kind): show one bundle, data a table MIME type ->
--             string holding exactly the accepted types the bundle has; kind
--             "result" (a value typed at the prompt, a cell's last
--             expression) or "display" (anything else)
--   print     function(text): a result that a library function prints itself
--             (a table of residuals, a verdict)
--   progress  function(): whether long runs draw a progress bar
local M = {}

local isatty = require("nz.core").mech.isatty

-- The terminal renders text only; what it prints is exactly what print
-- prints (plots in characters are drawn by nz/draw/plot.lua itself).
M.terminal = {
  name = "terminal",
  accepts = { ["text/plain"] = true },
  publish = function(data) print(data["text/plain"]) end,
  print = function(text) print(text) end,
  progress = function() return isatty(2) end,
}

local current = M.terminal

function M.current() return current end

-- Make `fe` the front-end (nil: the terminal again).
function M.use(fe) current = fe or M.terminal end

function M.accepts(mime) return current.accepts[mime] == true end
function M.publish(data, kind) return current.publish(data, kind or "display") end
function M.print(text) return current.print(text) end
function M.progress() return current.progress() end

-- What a function printed itself during the chunk being run.  A function
-- that prints its result and also returns it for scripts (nz.check's ok,
-- text; tr:residuals' table; nz.workprecision's rows) ends with
-- `return frontend.shown(...)`: typed at the prompt (or as a cell's last
-- expression), those same values are not printed a second time.  The
-- session forgets them before each chunk (M.begin), so the values kept in
-- a variable and typed later do print.  Weak: a record never keeps a
-- script's tables alive.
local shown = setmetatable({}, { __mode = "v" })

function M.shown(...)
  shown = setmetatable({ n = select("#", ...), ... }, { __mode = "v" })
  return ...
end

function M.begin() shown = setmetatable({}, { __mode = "v" }) end

function M.already_shown(...)
  local n = select("#", ...)
  if shown.n ~= n then return false end
  for i = 1, n do
    if not rawequal(shown[i], (select(i, ...))) then return false end
  end
  return true
end

return M

-- display_spec.lua - the display layer (nz/draw/display.lua) under the terminal
-- and under a notebook's front-end (nz/base/frontend.lua): each representation
-- built only when the front-end in use renders it, tables as HTML from
-- their rows, sys:show's LaTeX for MathJax; and the kernel's cells
-- (nz/session/kernel.lua: the last expression shown, the place of an error).
local h = require "tests.helpers"
local nz = h.nz
local display = require "nz.draw.display"
local frontend = require "nz.base.frontend"
local text = require "nz.base.text"
local kernel = require "nz.session.kernel"

-- A front-end that renders `mimes` and keeps what it is given.
local function notebook(mimes)
  local fe = { name = "test", accepts = {}, shown = {} }
  for _, m in ipairs(mimes) do fe.accepts[m] = true end
  function fe.publish(data, kind) fe.shown[#fe.shown + 1] = { data = data, kind = kind } end
  function fe.print(s) display.show(display.of(s)) end
  function fe.progress() return true end
  return fe
end

-- Run f with `fe` in use (and its tables kept when it renders HTML).
local function with(fe, f)
  frontend.use(fe)
  display.keep_tables(fe.accepts["text/html"])
  local ok, err = pcall(f)
  frontend.use(nil)
  display.keep_tables(false)
  assert(ok, err)
end

-- What print printed during f (the library calls the global print: busted
-- gives a spec file an environment of its own, so the real one is set).
local G = package.loaded._G
local function printed(f)
  local out, saved = {}, G.print
  G.print = function(...)
    local parts = {}
    for i = 1, select("#", ...) do parts[i] = tostring((select(i, ...))) end
    out[#out + 1] = table.concat(parts, "\t")
  end
  local ok, err = pcall(f)
  G.print = saved
  assert(ok, err)
  return table.concat(out, "\n")
end

local pend = nz.system{ name = "pendulum", coords = { "th" }, params = { m = 2.0, l = 1.3, g = 9.81 },
  T = function(t, q, qd, p) return 0.5 * p.m * p.l ^ 2 * qd[1] ^ 2 end,
  V = function(t, q, p) return -p.m * p.g * p.l * nz.cos(q[1]) end }

describe("the display layer", function()
  it("builds only the text in the terminal, and only what a notebook renders there", function()
    local built = {}
    local function rep(mime) return function() built[mime] = (built[mime] or 0) + 1; return mime .. " of x" end end
    local function bundle()
      return display.bundle{ ["text/plain"] = rep("text/plain"), ["text/latex"] = rep("text/latex"),
        ["text/html"] = rep("text/html"), ["image/svg+xml"] = rep("image/svg+xml") }
    end
    local out = printed(function() display.show(bundle()) end)
    assert(out == "text/plain of x", out)
    assert(built["text/plain"] == 1 and not built["text/latex"] and not built["text/html"] and not built["image/svg+xml"])
    local fe = notebook{ "text/plain", "text/latex" }
    built = {}
    with(fe, function() display.show(bundle()) end)
    assert(built["text/plain"] == 1 and built["text/latex"] == 1 and not built["text/html"] and not built["image/svg+xml"])
    assert(fe.shown[1].kind == "display" and fe.shown[1].data["text/latex"] == "text/latex of x")
  end)

  it("prints a value typed at the prompt as before: its text, tab-separated, nothing when shown already", function()
    local repl = require "nz.session.repl"
    assert(printed(function() repl.print(1.5, "a", { 1, 2 }) end) == "1.5\ta\t{1, 2}")
    assert(printed(function() repl.print(nil, nil) end) == "")
    repl.begin()
    local t = repl.shown({ 3 })
    assert(printed(function() repl.print(t) end) == "")
    repl.begin()
    assert(printed(function() repl.print(t) end) == "{3}")
    assert(printed(function() nz.print(math.pi, 0.1) end) == "3.141592653589793\t0.1")
  end)

  it("offers sys:show's LaTeX only to a front-end that typesets it", function()
    local s = pend:show{}
    assert(display.of(s).reps["text/latex"] == nil, "the terminal kept a LaTeX builder")
    local fe = notebook{ "text/plain", "text/latex" }
    with(fe, function()
      local shown = pend:show{}
      assert(shown == s, "the text changed in a notebook")
      local tex = display.of(shown):get("text/latex")
      -- the equations of the LaTeX form, each block in display math for MathJax
      assert(tex == display.latex(pend:show{ tex = true }), tex)
      assert(tex:find("^%$%$\\begin{aligned}\n") and tex:find("\n\\end{aligned}%$%$$"), tex)
    end)
    -- a block named in a comment becomes a title line, outside the mathematics
    assert(display.latex("\\begin{aligned}\n  a &= b\n\\end{aligned}\n% the mass matrix\n\\begin{aligned}\n  M &= 1\n\\end{aligned}")
      == "$$\\begin{aligned}\n  a &= b\n\\end{aligned}$$\nthe mass matrix:\n$$\\begin{aligned}\n  M &= 1\n\\end{aligned}$$")
  end)

  it("shows a table as HTML from its rows, beside the text around it", function()
    assert(text.on_table == nil, "the terminal watches tables")
    local fe = notebook{ "text/plain", "text/html" }
    with(fe, function()
      local lin = pend:linearize{ q = { 0 } }
      local b = display.of(lin)
      local html = b:get("text/html")
      assert(b:get("text/plain") == tostring(lin))
      assert(html:find('<pre>linearization of &#39;pendulum&#39;', 1, true) or html:find("<pre>linearization of 'pendulum'", 1, true), html)
      assert(html:find('<th style="text-align:left">eigenvalue</th>', 1, true), html)
      -- the frequency sqrt(g / l) in its own cell
      local cell = html:match('<td style="text%-align:right">([%d.]+)</td>')
      assert(math.abs(tonumber(cell) - math.sqrt(9.81 / 1.3)) < 1e-5, html)
      -- characters that mean something in HTML are escaped
      local t = text.table{ { "a<b", "x & y" }, { "1", "2" } }
      assert(display.html("before\n" .. t):find("<th style=\"text-align:left\">a&lt;b</th><th style=\"text-align:right\">x &amp; y</th>", 1, true))
      assert(display.html("no table here") == nil)
    end)
  end)

  it("sends a notebook's plot as an <img> of its SVG for HTML (nbconvert's too) and as a PNG for a PDF", function()
    local plot = require "nz.draw.plot"
    local drawn, real = {}, plot.drawn
    plot.drawn = function(ext, ...) drawn[#drawn + 1] = ext; return real(ext, ...) end
    local series = { { name = "line", x = { 0, 1, 2 }, y = { 0, 1, 4 } } }
    local fe = notebook(display.MIMES)
    local ok, err = pcall(with, fe, function() plot.lines{ series = series, title = "a plot", width = 70, height = 16 } end)
    -- a front-end that renders HTML and text only: no PNG made
    local html_only = notebook{ "text/plain", "text/html" }
    local drawn_all = #drawn
    if ok then ok, err = pcall(with, html_only, function() plot.lines{ series = series } end) end
    plot.drawn = real
    assert(ok, err)
    local data = fe.shown[1].data
    local html, png = data["text/html"], data["image/png"]
    assert(html and html:find([[alt="plot 'a plot': line"/>$]]), tostring(html):sub(-80))
    local svg = h.img_data(html, "image/svg+xml")
    assert(svg and svg:find("<svg", 1, true) and svg:find(">a plot</tspan>", 1, true), "no SVG of the plot in the <img>")
    assert(svg:find('width="560" height="256"', 1, true), "70 x 16 characters are 560 x 256 pixels")
    -- not as image/svg+xml: nbconvert's LaTeX would need Inkscape for it
    assert(data["image/svg+xml"] == nil)
    -- a PNG (its signature), 560 x 256 pixels (IHDR's width and height)
    assert(png and png:sub(1, 8) == "\137PNG\r\n\26\n", "no PNG")
    assert(string.unpack(">I4", png, 17) == 560 and string.unpack(">I4", png, 21) == 256,
      ("the PNG is %d x %d"):format(string.unpack(">I4", png, 17), string.unpack(">I4", png, 21)))
    assert(data["text/plain"] == "plot 'a plot': line")
    assert(drawn_all == 2 and #drawn == 3 and drawn[3] == "svg", table.concat(drawn, " "))
    assert(not html_only.shown[1].data["image/png"] and html_only.shown[1].data["text/html"])
  end)

  it("writes base64 as RFC 4648's examples", function()
    for plain, coded in pairs{ [""] = "", f = "Zg==", fo = "Zm8=", foo = "Zm9v", foob = "Zm9vYg==", fooba = "Zm9vYmE=",
        foobar = "Zm9vYmFy" } do
      assert(display.base64(plain) == coded, plain)
    end
  end)
end)

describe("the kernel's cells", function()
  local function run(code) return kernel.chunk(code, "In [7]")() end

  it("show the value of the whole cell, or of its last lines, when they are an expression", function()
    assert(run("20 + 22") == 42)
    assert(run("a_ = 20\na_ + 22") == 42)
    assert(select("#", run("b_ = 1\nc_ = 2")) == 0)
    assert(run("d_ = {\n  1, 2 }\nmath.max(\n  d_[1],\n  d_[2])\n\n") == 2)
    assert(select(2, run("e_ = 5\ne_, e_ * 2")) == 10)
  end)

  it("name their chunk 'In [n]', and an error's place reads 'In [n], line m'", function()
    local ok, err = pcall(run, "x_ = 1\nlocal y = x_ + nil")
    assert(not ok and err:find("^In %[7%]:2: attempt to perform arithmetic"), err)
    assert(kernel.located(err):find("^In %[7%], line 2: attempt to perform arithmetic"), kernel.located(err))
    local f, why = kernel.chunk("x = = 1", "In [8]")
    assert(not f and kernel.located(why):find("^In %[8%], line 1: unexpected symbol near '='"), why)
  end)
end)

-- layers_spec.lua - the Lua half keeps its floors (tools/requires.lua,
-- docs/architecture.md): no module requires one of a floor above its own,
-- no circle of requires forms, and the graph the architecture page shows
-- is the code's; and the code keeps its shape (tools/shape.lua: sizes of
-- files and functions, no include circle between C files).
local requires = dofile("tools/requires.lua")

describe("the Lua half's floors", function()
  local mods = requires.modules(".")

  it("every module sits in a floor's folder, and none requires one above it or in a circle", function()
    assert.truthy(#mods > 30, "the modules of lua/nz were not found")
    local bad = requires.violations(mods)
    assert.are.same({}, bad, table.concat(bad, "\n"))
  end)

  it("the check finds an upward require and a circle (it can fail)", function()
    local fake = {
      { name = "nz.base.a", path = "lua/nz/base/a.lua", floor = "base", requires = { "nz.model.b" } },
      { name = "nz.model.b", path = "lua/nz/model/b.lua", floor = "model", requires = { "nz.model.c" } },
      { name = "nz.model.c", path = "lua/nz/model/c.lua", floor = "model", requires = { "nz.model.b" } },
      { name = "nz.shelf.d", path = "lua/nz/shelf/d.lua", floor = "shelf", requires = {} },
    }
    local bad = table.concat(requires.violations(fake), "\n")
    assert.truthy(bad:find("nz.base.a (base) requires nz.model.b (model), a floor above it", 1, true), bad)
    assert.truthy(bad:find("a circle of requires: nz.model.b -> nz.model.c -> nz.model.b", 1, true), bad)
    assert.truthy(bad:find("folder 'shelf' is not a floor", 1, true), bad)
  end)

  it("sees every require in the code, bare 'nz' and inside functions, and none in comments or strings", function()
    local src = table.concat({
      'local a = require "nz.base.text"',
      'local function f() return require("nz").last end',
      "local g = function() return require 'nz.model.record' end",
      '-- require "nz.analysis.check" (a comment)',
      '--[[ require("nz.analysis.defect") ]]',
      'local msg = "see require(\'nz.motion.simulate\').MAX_MEMORY"',
      'local long = [==[ require "nz.draw.plot" ]==]',
      'local t = x.require("nz.session.help")',
    }, "\n")
    assert.are.same({ "nz.base.text", "nz.init", "nz.model.record" }, requires.scan_requires(src))
  end)

  it("docs/architecture.md shows the require graph as it is (lua5.4 tools/requires.lua prints it)", function()
    local f = assert(io.open("docs/architecture.md"))
    local doc = f:read("a")
    f:close()
    local shown = doc:match("<!%-%- requires: begin[^\n]*%-%->\n(.-)\n<!%-%- requires: end %-%->")
    assert.truthy(shown, "docs/architecture.md has no block between <!-- requires: begin --> and <!-- requires: end -->")
    -- (lua5.4 tools/requires.lua --write puts the graph there)
    assert.are.equal(requires.markdown(mods), shown)
  end)
end)

-- The code's shape (tools/shape.lua): files, functions and includes a
-- newcomer can read.
describe("the code's shape", function()
  local shape = dofile("tools/shape.lua")

  it("no source file over 1,200 lines, no C function over 150, no Lua function over 200, no include circle", function()
    local bad = shape.violations(".")
    assert.are.same({}, bad, table.concat(bad, "\n"))
  end)

  it("the check sees a long C function, a long Lua function and an include circle (it can fail)", function()
    local body = { "int f(void)", "{" }
    for i = 1, 160 do body[#body + 1] = ("  x += %d;"):format(i) end
    body[#body + 1] = "}"
    local fs = shape.c_functions(body)
    assert.are.equal(1, #fs)
    assert.are.equal("f", fs[1].name)
    assert.truthy(fs[1].lines > shape.MAX_C_FUNCTION)
    local lua = { "local function g()" }
    for i = 1, 210 do lua[#lua + 1] = ("  y = %d"):format(i) end
    lua[#lua + 1] = "end"
    local gs = shape.lua_functions(lua)
    assert.truthy(#gs == 1 and gs[1].lines > shape.MAX_LUA_FUNCTION)
    local circles = shape.include_circles({
      ["src/a/x"] = { ["src/a/y"] = true }, ["src/a/y"] = { ["src/a/x"] = true }, ["src/a/z"] = {},
    })
    assert.are.equal(1, #circles)
    assert.truthy(circles[1]:find("src/a/x -> src/a/y -> src/a/x", 1, true), circles[1])
  end)

  it("a private header X_impl.h counts as X's own, not as a circle", function()
    local dir = os.tmpname()
    os.remove(dir)
    assert(os.execute(("mkdir -p %s/src/m"):format(dir)))
    local function put(name, text)
      local f = assert(io.open(dir .. "/src/m/" .. name, "w"))
      f:write(text)
      f:close()
    end
    put("x.h", "int x(void);\n")
    put("x_impl.h", '#include "m/x.h"\n')
    put("x.c", '#include "m/x_impl.h"\n')
    put("x_more.c", '#include "m/x_impl.h"\n')
    assert.are.same({}, shape.include_circles(shape.includes(dir)))
    put("x.h", '#include "m/x_more.h"\n')
    put("x_more.h", '#include "m/x.h"\n')
    assert.are.equal(1, #shape.include_circles(shape.includes(dir)))
    os.execute(("rm -rf %s"):format(dir))
  end)
end)

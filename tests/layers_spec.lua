-- layers_spec.lua - the Lua half keeps its floors (tools/requires.lua,
-- docs/architecture.md): no module requires one of a floor above its own,
-- no circle of requires forms, and the graph the architecture page shows
-- is the code's.
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

-- packages_spec.lua - what each make target installs: `make demo` only what
-- building and running need, the kernel's packages only for `make kernel`
-- and `make install`, and `make test` everything the suite uses (so that CI,
-- which runs `make test` on a fresh machine, installs what it did).  Read
-- from `make -n` (the line tools/deps.sh would run), and checked by running
-- the demo with nothing on its PATH but the programs of the demo's packages.
local h = require "tests.helpers"

-- The packages `make -n TARGET` hands to tools/deps.sh, as a set and a list.
local function installs(target)
  local code, out, err = h.run("make -n " .. target)
  assert(code == 0, ("make -n %s failed:\n%s%s"):format(target, out, err))
  local line = out:match("tools/deps%.sh([^\n]*)")
  assert(line, ("make %s installs nothing through tools/deps.sh:\n%s"):format(target, out))
  local set, list = {}, {}
  for p in line:gmatch("%S+") do set[p], list[#list + 1] = true, p end
  return set, list
end

local function set_of(list) local s = {}; for _, p in ipairs(list) do s[p] = true end; return s end

-- What building and running need: the compiler, Lua, readline, GSL, gnuplot.
local DEMO = { "make", "gcc", "pkg-config", "liblua5.4-dev", "lua5.4", "libreadline-dev", "libgsl-dev", "gnuplot-nox" }
-- The Jupyter kernel: ipykernel, the notebook, MathJax and three.js.
local KERNEL = { "python3-ipykernel", "jupyter-client", "python3-zmq", "jupyter-notebook", "jupyter-nbconvert", "libjs-mathjax",
  "libjs-three" }
-- What the suite uses besides (busted runs it, tmux drives the session,
-- numpy runs sys:export's Python, parallel the sweeps, nbclient, nbconvert
-- and chromium the notebook): with the two sets above, every package that
-- `make test` installed before the sets were split, and three.js.
local TESTS = { "lua-busted", "tmux", "python3-numpy", "parallel", "python3-nbclient", "python3-nbconvert", "chromium" }

describe("the Debian packages each target installs", function()
  it("make demo: the compiler, Lua, readline, GSL and gnuplot, nothing else", function()
    local set, list = installs("demo")
    local want = set_of(DEMO)
    for _, p in ipairs(list) do
      assert(want[p], ("make demo installs %s, which building and running do not need"):format(p))
    end
    for _, p in ipairs(DEMO) do assert(set[p], ("make demo does not install %s"):format(p)) end
  end)

  it("make kernel and make install: the demo's and the kernel's, no test tool", function()
    for _, target in ipairs{ "kernel", "install" } do
      local set, list = installs(target)
      local want = set_of(DEMO)
      for _, p in ipairs(KERNEL) do want[p] = true end
      for _, p in ipairs(list) do
        assert(want[p], ("make %s installs %s, which the kernel does not need"):format(target, p))
      end
      for p in pairs(want) do assert(set[p], ("make %s does not install %s"):format(target, p)) end
    end
  end)

  it("make test (and make deps): every package the suite uses", function()
    for _, target in ipairs{ "test", "deps", "check" } do
      local set = installs(target)
      for _, group in ipairs{ DEMO, KERNEL, TESTS } do
        for _, p in ipairs(group) do assert(set[p], ("make %s does not install %s"):format(target, p)) end
      end
    end
  end)

  it("the README's quick start names each package of each set", function()
    local readme = assert(h.slurp("README.md"))
    local start = assert(readme:find("## Quick start", 1, true))
    local section = readme:sub(start, readme:find("\n## ", start + 1, true))
    local named = {}
    for code in section:gmatch("`([^`]+)`") do for word in code:gmatch("%S+") do named[word] = true end end
    local _, list = installs("test")
    for _, p in ipairs(list) do
      assert(named[p], ("the README's quick start does not name %s, which make test installs"):format(p))
    end
    for _, name in ipairs{ "DEMO_PKGS", "KERNEL_PKGS", "TEST_PKGS" } do
      assert(named[name], "the quick start does not name the Makefile's " .. name)
    end
  end)

  -- The installed packages that `roots` need: their Depends and
  -- Pre-Depends, every alternative that is installed, and the Essential
  -- ones (always on a Debian machine).
  local function closure(roots)
    local p = io.popen("dpkg-query -W -f='${db:Status-Abbrev}\\t${Package}\\t${Essential}\\t${Pre-Depends}, ${Depends}\\n'")
    local deps, need, todo = {}, {}, {}
    for line in p:lines() do
      local status, name, essential, list = line:match("^(%S+)%s*\t([^\t]+)\t([^\t]*)\t(.*)$")
      if status and status:sub(2, 2) == "i" then
        deps[name] = {}
        for alt in list:gmatch("[^,|]+") do
          local dep = alt:match("^%s*([%w%.%+%-]+)")
          if dep then deps[name][#deps[name] + 1] = dep end
        end
        if essential == "yes" then todo[#todo + 1] = name end
      end
    end
    p:close()
    for _, r in ipairs(roots) do todo[#todo + 1] = r end
    while #todo > 0 do
      local name = table.remove(todo)
      if deps[name] and not need[name] then
        need[name] = true
        for _, d in ipairs(deps[name]) do todo[#todo + 1] = d end
      end
    end
    return need
  end

  it("runs examples/demo.lua with only the programs of the demo's packages on its PATH", function()
    local need = closure(DEMO)
    local names = {}
    for name in pairs(need) do names[#names + 1] = name end
    local files = {}
    local p = io.popen("dpkg-query -L " .. table.concat(names, " ") .. " 2>/dev/null")
    for line in p:lines() do files[line] = true end
    p:close()
    -- a program on PATH is theirs when it, or what it links to (Debian's
    -- alternatives: gnuplot -> gnuplot-nox), is one of their files
    local bin = os.tmpname()
    os.remove(bin)
    assert(os.execute("mkdir -p " .. bin))
    local links = {}
    for _, dir in ipairs{ "/usr/bin", "/bin" } do
      local q = io.popen(("cd %s && for f in *; do printf '%%s\\n' \"$f\"; done; realpath -m -- *"):format(dir))
      local lines = {}
      for line in q:lines() do lines[#lines + 1] = line end
      q:close()
      local half = #lines // 2
      for i = 1, half do
        local name, real = lines[i], lines[half + i]
        if files[dir .. "/" .. name] or files[real] then links[#links + 1] = ("ln -sf %s/%s %s/"):format(dir, name, bin) end
      end
    end
    local n = #links
    assert(os.execute(table.concat(links, "\n")))
    assert(n > 50, "found only " .. n .. " programs of the demo's packages")
    assert(io.open(bin .. "/gnuplot"), "gnuplot is not among the demo's programs")
    assert(not io.open(bin .. "/python3") and not io.open(bin .. "/chromium"), "the demo's PATH has python3 or chromium")
    local cache = os.tmpname()
    os.remove(cache)
    local code, out, err = h.run(("env -i HOME=%s PATH=%s NZLUA_CACHE=%s %s examples/demo.lua"):format(cache, bin, cache,
      h.nzlua))
    os.execute("rm -rf " .. bin .. " " .. cache)
    assert(code == 0, "the demo failed with the demo's packages alone:\n" .. err)
    assert(out:find("period: simulated", 1, true) and err == "", out .. err)
  end)
end)

-- nz/presentation/contact_laws.lua - how a system's unilateral contacts
-- (nz/model/contact.lua, docs/theory.md §13) enter what sys:show, sys:rule
-- and sys:export say: each contact's force in the equations (N_name on its
-- gap's gradient, T_name on its slip's), its complementarity, its friction
-- law and its impact law as formulas; the rule's sentence; export's refusal.
local formula = require "nz.base.formula"

local M = {}

local function num(v) return require("nz.base.text").number(v) end

-- The multipliers of the contact system's constraints (sys.contact.system:
-- the equalities, then each contact's gap and slips) as the equations name
-- them: lambda_r for the equalities, N_name for a gap, T_name (T1_name,
-- T2_name for an isotropic cone) for a slip; nil for a cone's speed |v_t|,
-- which is no force.  Returns a function r -> symbol or nil.
function M.multipliers(sys)
  local c = sys.contact
  local name_of, skip = {}, {}
  for j, s in ipairs(c.contacts) do
    local nm = c.names[j]
    name_of[s.gap] = { "N", nm }
    if s.slip2 then
      name_of[s.slip], name_of[s.slip2], skip[s.speed] = { "T1", nm }, { "T2", nm }, true
    elseif s.slip then name_of[s.slip] = { "T", nm } end
  end
  return function(r)
    if skip[r] then return nil end
    local lua = ("lambda[%d]"):format(r)
    local n = name_of[r]
    if not n then return formula.symbol("lambda" .. r, { lua = lua, base = "lambda_" .. r }) end
    local plain = n[2]:gsub("[^%w_]", "_")
    local tex_name = n[2]:gsub("([_#%%&{}$])", "\\%1")
    local index = #n[1] > 1 and (n[1]:sub(2) .. ",") or ""
    return formula.symbol(n[1] .. "_" .. plain, { lua = lua,
      tex = ("%s_{%s\\mathrm{%s}}"):format(n[1]:sub(1, 1), index, tex_name) })
  end
end

-- The symbol of contact j's force kind ("N", "T", "T1", "T2") in lang.
local function force(sys, j, kind, lang)
  local s = sys.contact.contacts[j]
  local r = kind == "N" and s.gap or kind == "T2" and s.slip2 or s.slip
  return formula.print(M.multipliers(sys)(r), lang)
end

-- The lines of sys:show's section on contacts: per contact its gap and
-- complementarity, its friction law with its slip velocity, its impact law.
-- eq: the contact system's equations (phi: its constraints as formulas).
function M.show_lines(sys, eq, lang, names)
  local c, out = sys.contact, {}
  local tex = lang == "tex"
  local function p(r) return formula.print(eq.phi[r], lang, names, true) end
  for j, s in ipairs(c.contacts) do
    local nm, spec = c.names[j], s
    local N = force(sys, j, "N", lang)
    local gname = tex and ("g_{\\mathrm{%s}}"):format(nm) or ("g_" .. nm)
    if tex then
      out[#out + 1] = ("%s = %s &\\ge 0, \\quad %s \\ge 0, \\quad %s \\, %s = 0"):format(gname, p(s.gap), N, gname, N)
    else
      out[#out + 1] = ("  %s:  %s = %s >= 0,  %s >= 0,  %s %s = 0   (held, %s'' = 0, while it pushes)"):format(
        nm, gname, p(s.gap), N, gname, N, gname)
    end
    if s.slip then
      local mu, mus = spec.mu, spec.mu_s
      local T, v
      if s.slip2 then
        T = tex and ("\\mathbf{T}_{\\mathrm{%s}}"):format(nm) or ("(%s, %s)"):format(force(sys, j, "T1", lang),
          force(sys, j, "T2", lang))
        v = ("(%s, %s)"):format(p(s.slip), p(s.slip2))
      else
        T, v = force(sys, j, "T", lang), p(s.slip)
      end
      if tex then
        out[#out + 1] = ("\\lvert %s \\rvert &\\le \\mu_{s} %s, \\quad %s = -\\mu \\, %s \\, \\frac{v_t}{\\lvert v_t \\rvert} "
          .. "\\text{ while } v_t = %s \\ne 0 \\quad (\\mu = %s, \\ \\mu_{s} = %s)"):format(T, N, T, N, v, num(mu), num(mus))
      else
        out[#out + 1] = ("       friction: |%s| <= mu_s %s while it sticks (v_t = 0), %s = -mu %s v_t/|v_t| while it "
          .. "slides, v_t = %s  (mu = %s, mu_s = %s%s)"):format(T, N, T, N, v, num(mu), num(mus),
          s.slip2 and ", an isotropic cone" or "")
      end
    end
    if tex then
      out[#out + 1] = ("v_{n}^{+} &= -e \\, v_{n}^{-} \\quad (e = %s, \\text{ %s at an impact})"):format(num(spec.e), nm)
    else
      out[#out + 1] = ("       impact: Newton's law v_n+ = -e v_n- (e = %s), with every touching contact at once"):format(
        num(spec.e))
    end
  end
  return out
end

-- The sentence sys:rule adds: how many contacts, how they enter.
function M.rule_text(sys)
  local c = sys.contact
  local fr = 0
  for _, s in ipairs(c.contacts) do if s.slip then fr = fr + 1 end end
  return ("The system also has %d unilateral contact%s (%s): each enters by its force on its gap's gradient "
    .. "(N >= 0, gap >= 0, their product 0), held as a constraint of order 0 while it pushes%s, and changes at "
    .. "events and impacts (docs/theory.md §13); they need no higher order."):format(c.n, c.n == 1 and "" or "s",
    table.concat(c.names, ", "), fr > 0 and (", its friction (%d of them) as one of order 1 on its slip velocity "
    .. "while it sticks"):format(fr) or "")
end

-- Why sys:export refuses a system with contacts (and what it can do).
function M.export_refusal(sys)
  local c = sys.contact
  return ("'%s' has %d unilateral contact%s (%s): the exported code integrates smooth equations, without the "
    .. "contacts' events, impacts and forces, so its motion would pass through them; export{smooth = true} writes "
    .. "the smooth part (the system without its contacts) and says so in the file"):format(sys.name, c.n,
    c.n == 1 and "" or "s", table.concat(c.names, ", "))
end

-- The line export{smooth = true} puts first in the file.
function M.export_note(sys)
  return ("the smooth part of '%s' only: its unilateral contacts (%s) are left out (no events, impacts or contact "
    .. "forces: the motion passes through them)"):format(sys.name, table.concat(sys.contact.names, ", "))
end

return M

#include "mlp/nc/nc_output.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <sstream>

namespace mlp::nc {
namespace {

[[noreturn]] void Fail(const std::string& what) { throw NcOutputError(what); }

// mm to 0.1 um: beyond every control's input resolution, so nothing is rounded twice.
std::string Num(double v) {
  if (!std::isfinite(v)) Fail("an offset value is not a finite number");
  char buf[48];
  std::snprintf(buf, sizeof buf, "%.4f", v);
  return std::string(buf) == "-0.0000" ? "0.0000" : buf;
}

// NC comments may not hold parentheses; controls differ on lower case and length.
std::string Comment(const std::string& text) {
  std::string s;
  for (char c : text) s += (c == '(' || c == ')' || c == '\n' || c == '\r') ? ' ' : c;
  if (s.empty()) return s;
  std::string out = "(";
  out.append(s, 0, 120);
  out.append(")\n");
  return out;
}

void CheckName(const std::string& name) {
  if (name.empty()) Fail("a parameter name is empty");
  for (char c : name) {
    if (!(std::islower(static_cast<unsigned char>(c)) ||
          std::isdigit(static_cast<unsigned char>(c)) || c == '_'))
      Fail("parameter name '" + name + "': only a-z, 0-9 and _");
  }
}

bool IsWear(ToolRegister r) {
  return r == ToolRegister::kLengthWear || r == ToolRegister::kRadiusWear;
}
bool IsLength(ToolRegister r) {
  return r == ToolRegister::kLengthGeometry || r == ToolRegister::kLengthWear;
}

void CheckTool(const ToolOffsetChange& t, int max) {
  if (t.tool < 1 || t.tool > max)
    Fail("offset number " + std::to_string(t.tool) + " is outside 1.." + std::to_string(max));
  if (t.reg == ToolRegister::kRadiusGeometry && t.after_mm < 0)
    Fail("tool " + std::to_string(t.tool) + ": a negative radius geometry");
}

const char* const kAxes[3] = {"X", "Y", "Z"};

}  // namespace

std::string ToString(ToolRegister r) {
  switch (r) {
    case ToolRegister::kLengthGeometry:
      return "length geometry";
    case ToolRegister::kLengthWear:
      return "length wear";
    case ToolRegister::kRadiusGeometry:
      return "radius geometry";
    case ToolRegister::kRadiusWear:
      return "radius wear";
    case ToolRegister::kOffsetX:
      return "offset X";
    case ToolRegister::kOffsetY:
      return "offset Y";
    case ToolRegister::kOffsetC:
      return "offset C";
  }
  return "?";
}

std::optional<ToolRegister> ToolRegisterFrom(const std::string& text) {
  // Also as requests spell registers ("radius_wear", "offset_x"): underscores for spaces,
  // any case.
  std::string spaced = text;
  for (char& c : spaced) c = c == '_' ? ' ' : static_cast<char>(std::tolower(c));
  for (const ToolRegister r :
       {ToolRegister::kLengthGeometry, ToolRegister::kLengthWear, ToolRegister::kRadiusGeometry,
        ToolRegister::kRadiusWear, ToolRegister::kOffsetX, ToolRegister::kOffsetY,
        ToolRegister::kOffsetC})
    if (std::string name = ToString(r);
        std::equal(name.begin(), name.end(), spaced.begin(), spaced.end(),
                   [](char a, char b) { return std::tolower(a) == b; }))
      return r;
  return std::nullopt;
}

char OffsetWord(ToolRegister r) {
  return r == ToolRegister::kOffsetX   ? 'X'
         : r == ToolRegister::kOffsetY ? 'Y'
         : r == ToolRegister::kOffsetC ? 'C'
                                       : '\0';
}

NcMap FanucMap() {
  NcMap m;
  m.dialect = Dialect::kFanuc;
  m.length_geometry_var = 11001, m.length_wear_var = 10001;
  m.radius_geometry_var = 13001, m.radius_wear_var = 12001;
  m.max_offset = 200;
  return m;
}

NcMap HaasMap() {
  NcMap m;
  m.dialect = Dialect::kHaas;
  m.length_geometry_var = 2001, m.length_wear_var = 2201;
  m.radius_geometry_var = 2401, m.radius_wear_var = 2601;
  m.max_offset = 200;
  m.radius_as_diameter = true;
  m.max_extended_work = 99;
  return m;
}

NcMap SyntecMap() {
  NcMap m;
  m.dialect = Dialect::kSyntec;
  m.radius_as_diameter = true;
  return m;
}

std::string WorkOffsetName(Dialect d, int index) {
  static const char* const kBase[] = {"G54", "G55", "G56", "G57", "G58", "G59"};
  if (index >= 1 && index <= 6) return kBase[index - 1];
  if (index < 1) Fail("work offset index must be 1 or more");
  const int n = index - 6;
  if (d == Dialect::kLinuxCnc) {
    if (n > 3) Fail("LinuxCNC has 9 work offsets (G54..G59.3)");
    return std::string("G59.").append(std::to_string(n));
  }
  return std::string(d == Dialect::kHaas ? "G154 P" : "G54.1 P").append(std::to_string(n));
}

std::string LinuxCncSubroutine(const std::string& name, const NcResult& r) {
  CheckName(name);
  std::ostringstream s;
  s << "o<" << name << "> sub\n" << Comment(r.header);
  for (const ToolOffsetChange& t : r.tools) {
    CheckTool(t, 99999);
    if (t.incremental)
      Fail("LinuxCNC takes the new value: read the tool table for tool " + std::to_string(t.tool));
    if (IsWear(t.reg))
      Fail("LinuxCNC has no wear registers: tool " + std::to_string(t.tool) + " " +
           ToString(t.reg) + " (apply the change to the geometry)");
    const char word = OffsetWord(t.reg) != 0 ? OffsetWord(t.reg) : IsLength(t.reg) ? 'Z' : 'R';
    s << "G10 L1 P" << t.tool << " " << word << Num(t.after_mm) << "\n";
  }
  for (const WorkOffsetChange& w : r.work) {
    WorkOffsetName(Dialect::kLinuxCnc, w.index);  // range check
    s << "G10 L2 P" << w.index;
    // LinuxCNC keeps G54..G59.3 in parameters 5221 + 20 (index - 1) + axis.
    const int x_param = 5221 + 20 * (w.index - 1);
    for (int a = 0; a < 3; ++a) {
      if (!w.axes[a]) continue;
      const double shift = w.after_mm[a] - w.before_mm[a];
      if (w.incremental)
        s << " " << kAxes[a] << "[#" << x_param + a << (shift < 0 ? " - " : " + ")
          << Num(std::abs(shift)) << "]";
      else
        s << " " << kAxes[a] << Num(w.after_mm[a]);
    }
    if (w.rotation_after_deg) s << " R" << Num(*w.rotation_after_deg);
    s << "\n";
  }
  for (const auto& [key, value] : r.named) {
    CheckName(key);
    s << "#<_mlp_" << key << "> = " << Num(value) << "\n";
  }
  if (!r.numbered.empty()) Fail("LinuxCNC results use named parameters, not numbered ones");
  s << "o<" << name << "> endsub\nM2\n";
  return s.str();
}

namespace {

// One tool offset change: through the macro variables of the register (map.use_variables), or
// as G10 L10..L13.
void FanucToolChange(const NcMap& map, const ToolOffsetChange& t, std::ostream& s) {
  CheckTool(t, map.use_variables ? map.max_offset : 9999);
  if (OffsetWord(t.reg) != 0)
    Fail("a tool's " + ToString(t.reg) +
         " has no register on this control (LinuxCNC's table only)");
  const double scale = !IsLength(t.reg) && map.radius_as_diameter ? 2.0 : 1.0;
  const double value = scale * (t.incremental ? t.after_mm - t.before_mm : t.after_mm);
  if (map.use_variables) {
    const int base = t.reg == ToolRegister::kLengthGeometry   ? map.length_geometry_var
                     : t.reg == ToolRegister::kLengthWear     ? map.length_wear_var
                     : t.reg == ToolRegister::kRadiusGeometry ? map.radius_geometry_var
                                                              : map.radius_wear_var;
    if (base <= 0) Fail("the variable map has no " + ToString(t.reg) + " variables");
    const int var = base + t.tool - 1;
    if (t.incremental)
      s << "#" << var << " = #" << var << (value < 0 ? " - " : " + ") << Num(std::abs(value))
        << "\n";
    else
      s << "#" << var << " = " << Num(value) << "\n";
    return;
  }
  const int l = t.reg == ToolRegister::kLengthGeometry   ? 10
                : t.reg == ToolRegister::kLengthWear     ? 11
                : t.reg == ToolRegister::kRadiusGeometry ? 12
                                                         : 13;
  if (t.incremental)  // G91: R is added to the register; back to G90 at once
    s << "G91 G10 L" << l << " P" << t.tool << " R" << Num(value) << "\nG90\n";
  else
    s << "G10 L" << l << " P" << t.tool << " R" << Num(value) << "\n";
}

// One work offset change: through the macro variables (map.use_variables), or as G10 L2 / L20;
// its rotation through the variable the macro's G68 reads.
void FanucWorkChange(const NcMap& map, const WorkOffsetChange& w, std::ostream& s) {
  const bool extended = w.index > 6;
  if (extended && w.index - 6 > map.max_extended_work)
    Fail(WorkOffsetName(map.dialect, w.index) + " is beyond the machine's " +
         std::to_string(map.max_extended_work) + " extended work offsets");
  WorkOffsetName(map.dialect, w.index);
  if (map.use_variables) {
    const int x = extended ? map.extended_work_var + (w.index - 7) * map.extended_work_stride
                           : map.work_var + (w.index - 1) * map.work_stride;
    for (int a = 0; a < 3; ++a) {
      if (!w.axes[a]) continue;
      const double shift = w.after_mm[a] - w.before_mm[a];
      if (w.incremental)
        s << "#" << x + a << " = #" << x + a << (shift < 0 ? " - " : " + ") << Num(std::abs(shift))
          << "\n";
      else
        s << "#" << x + a << " = " << Num(w.after_mm[a]) << "\n";
    }
  } else {
    // G91: the values are added to the offset; back to G90 at once.
    s << (w.incremental ? "G91 G10 " : "G10 ")
      << (extended ? "L20 P" + std::to_string(w.index - 6) : "L2 P" + std::to_string(w.index));
    for (int a = 0; a < 3; ++a)
      if (w.axes[a])
        s << " " << kAxes[a] << Num(w.incremental ? w.after_mm[a] - w.before_mm[a] : w.after_mm[a]);
    s << (w.incremental ? "\nG90\n" : "\n");
  }
  if (w.rotation_after_deg) {
    if (map.rotation_var <= 0)
      Fail(
          "the control keeps no rotation with a work offset: configure rotation_var for the "
          "macro's G68");
    s << "#" << map.rotation_var << " = " << Num(*w.rotation_after_deg) << "\n";
  }
}

}  // namespace

std::string FanucStyleSnippet(const NcMap& map, const NcResult& r) {
  if (map.dialect == Dialect::kLinuxCnc) Fail("LinuxCNC takes LinuxCncSubroutine");
  if (map.use_variables && (map.length_geometry_var <= 0 || map.radius_geometry_var <= 0))
    Fail("the machine's variable map has no tool offset variables: configure them");
  std::ostringstream s;
  s << Comment(r.header) << "G90\n";
  for (const ToolOffsetChange& t : r.tools) FanucToolChange(map, t, s);
  for (const WorkOffsetChange& w : r.work) FanucWorkChange(map, w, s);
  for (const auto& [var, value] : r.numbered) {
    if (var < 1) Fail("variable numbers start at 1");
    s << "#" << var << " = " << Num(value) << "\n";
  }
  if (!r.named.empty()) Fail("Fanuc-style results use numbered variables, not named ones");
  return s.str();
}

}  // namespace mlp::nc

#include "campaign/report.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <vector>

#include "campaign/stats.h"
#include "core/error.h"
#include "core/file_io.h"

namespace mm {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

std::string esc(const std::string& s) {
  std::string o;
  for (const char c : s) {
    if (c == '<') o += "&lt;";
    else if (c == '>') o += "&gt;";
    else if (c == '&') o += "&amp;";
    else if (c == '"') o += "&quot;";
    else o += c;
  }
  return o;
}

std::string num(double v, int precision) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", precision, v);
  return buf;
}

json readJson(const fs::path& p) {
  if (!fs::exists(p)) throw InputError(p.string(), "not found");
  try {
    return json::parse(std::ifstream(p));
  } catch (const std::exception& e) {
    throw InputError(p.string(), std::string("not JSON: ") + e.what());
  }
}

// ---- plots as SVG --------------------------------------------------------------------------------

constexpr int kWidth = 680;
const char* kFont = "font-family=\"sans-serif\" font-size=\"12\"";

std::string svgOpen(const std::string& id, int height) {
  return "<svg class=\"plot\" id=\"" + id + "\" xmlns=\"http://www.w3.org/2000/svg\" width=\"" + std::to_string(kWidth) +
         "\" height=\"" + std::to_string(height) + "\" viewBox=\"0 0 " + std::to_string(kWidth) + " " + std::to_string(height) +
         "\" " + kFont + ">\n<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n";
}

std::string text(double x, double y, const std::string& s, const char* anchor = "start", const char* extra = "") {
  return "<text x=\"" + num(x, 1) + "\" y=\"" + num(y, 1) + "\" text-anchor=\"" + anchor + "\" " + extra + ">" + esc(s) + "</text>\n";
}

std::string line(double x1, double y1, double x2, double y2, const char* stroke = "#444", double width = 1) {
  return "<line x1=\"" + num(x1, 1) + "\" y1=\"" + num(y1, 1) + "\" x2=\"" + num(x2, 1) + "\" y2=\"" + num(y2, 1) + "\" stroke=\"" +
         stroke + "\" stroke-width=\"" + num(width, 1) + "\"/>\n";
}

/// A round step for about `n` ticks over `span`.
double niceStep(double span, int n) {
  if (span <= 0) return 1;
  const double raw = span / n, mag = std::pow(10.0, std::floor(std::log10(raw)));
  for (const double m : {1.0, 2.0, 5.0, 10.0})
    if (raw <= m * mag) return m * mag;
  return 10 * mag;
}

struct Bar {
  std::string label;
  double value = 0;
  double lo = NAN, hi = NAN;  ///< an interval drawn as a whisker
  std::string shown;          ///< the text beside the bar
};

/// Horizontal bars from 0 to `max_value` (the largest value when 0).
std::string barChart(const std::string& id, const std::vector<Bar>& bars, const std::string& axis, double max_value = 0) {
  for (const Bar& b : bars) max_value = std::max({max_value, b.value, std::isnan(b.hi) ? 0.0 : b.hi});
  if (max_value <= 0) max_value = 1;
  const double x0 = 200, w = 360, row = 24;
  const int height = static_cast<int>(40 + row * bars.size() + 30);
  std::string s = svgOpen(id, height);
  for (size_t i = 0; i < bars.size(); ++i) {
    const Bar& b = bars[i];
    const double y = 20 + row * i;
    s += text(x0 - 8, y + 15, b.label, "end");
    s += "<rect x=\"" + num(x0, 1) + "\" y=\"" + num(y + 3, 1) + "\" width=\"" + num(std::max(0.0, w * b.value / max_value), 1) +
         "\" height=\"" + num(row - 8, 1) + "\" fill=\"#4878a8\"/>\n";
    if (!std::isnan(b.lo) && !std::isnan(b.hi)) {
      const double a = x0 + w * b.lo / max_value, c = x0 + w * b.hi / max_value, m = y + row / 2 - 1;
      s += line(a, m, c, m, "#111", 1.5) + line(a, m - 5, a, m + 5, "#111", 1.5) + line(c, m - 5, c, m + 5, "#111", 1.5);
    }
    s += text(x0 + w + 8, y + 15, b.shown);
  }
  const double yb = 20 + row * bars.size() + 4;
  s += line(x0, yb, x0 + w, yb);
  const double step = niceStep(max_value, 5);
  for (double v = 0; v <= max_value * 1.0001; v += step) {
    const double x = x0 + w * v / max_value;
    s += line(x, yb, x, yb + 4) + text(x, yb + 16, num(v, step < 1 ? (step < 0.1 ? 2 : 1) : 0), "middle");
  }
  s += text(x0 + w / 2, yb + 30, axis, "middle");
  return s + "</svg>\n";
}

std::string histogram(const std::string& id, const std::vector<double>& values, const std::string& axis, int bins = 20) {
  const double height = 240, x0 = 60, y0 = 200, w = kWidth - 100, h = 170;
  std::string s = svgOpen(id, static_cast<int>(height));
  if (values.empty()) return s + text(kWidth / 2.0, 100, "no successful trial", "middle") + "</svg>\n";
  double lo = *std::min_element(values.begin(), values.end()), hi = *std::max_element(values.begin(), values.end());
  if (hi - lo < 1e-9) lo -= 0.5, hi += 0.5;
  const double step = niceStep(hi - lo, bins);
  lo = std::floor(lo / step) * step;
  hi = std::ceil(hi / step) * step + (std::fmod(hi, step) == 0 ? step : 0);
  const int n = std::max(1, static_cast<int>(std::lround((hi - lo) / step)));
  std::vector<long> count(n, 0);
  for (const double v : values) count[std::clamp(static_cast<int>((v - lo) / step), 0, n - 1)]++;
  const long top = *std::max_element(count.begin(), count.end());
  for (int i = 0; i < n; ++i) {
    const double bh = h * count[i] / std::max(top, 1L);
    s += "<rect x=\"" + num(x0 + w * i / n + 1, 1) + "\" y=\"" + num(y0 - bh, 1) + "\" width=\"" + num(w / n - 2, 1) +
         "\" height=\"" + num(bh, 1) + "\" fill=\"#4878a8\"><title>" + num(lo + i * step, 2) + "–" + num(lo + (i + 1) * step, 2) +
         ": " + std::to_string(count[i]) + "</title></rect>\n";
  }
  s += line(x0, y0, x0 + w, y0) + line(x0, y0, x0, y0 - h);
  const double tick = niceStep(hi - lo, 6);
  for (double v = std::ceil(lo / tick) * tick; v <= hi + 1e-9; v += tick) {
    const double x = x0 + w * (v - lo) / (hi - lo);
    s += line(x, y0, x, y0 + 4) + text(x, y0 + 16, num(v, tick < 1 ? 1 : 0), "middle");
  }
  s += text(x0 - 6, y0 - h + 4, std::to_string(top), "end") + text(x0 - 6, y0 + 4, "0", "end");
  s += text(x0 + w / 2, y0 + 32, axis, "middle") + text(14, y0 - h / 2, "trials", "middle", "transform=\"rotate(-90 14 115)\"");
  return s + "</svg>\n";
}

struct Point {
  double x = 0, y = 0;
  std::string label;
};

/// A scatter plot; `circle` > 0 draws a circle of that radius about the origin (a tolerance).
std::string scatter(const std::string& id, const std::vector<Point>& pts, const std::string& xaxis, const std::string& yaxis,
                    bool equal_axes, double circle = 0, bool log_x = false) {
  const double x0 = 70, y0 = 300, w = equal_axes ? 270 : kWidth - 260, h = 270;
  std::string s = svgOpen(id, 350);
  auto fx = [&](double v) { return log_x ? std::log10(std::max(v, 1e-9)) : v; };
  double xlo = 1e300, xhi = -1e300, ylo = 1e300, yhi = -1e300;
  for (const Point& p : pts) xlo = std::min(xlo, fx(p.x)), xhi = std::max(xhi, fx(p.x)), ylo = std::min(ylo, p.y), yhi = std::max(yhi, p.y);
  if (pts.empty()) xlo = ylo = -1, xhi = yhi = 1;
  if (circle > 0) xlo = std::min(xlo, -circle), xhi = std::max(xhi, circle), ylo = std::min(ylo, -circle), yhi = std::max(yhi, circle);
  if (equal_axes) {
    const double r = std::max({std::abs(xlo), std::abs(xhi), std::abs(ylo), std::abs(yhi)}) * 1.1;
    xlo = ylo = -r, xhi = yhi = r;
  } else {
    const double px = std::max(xhi - xlo, 1e-9) * 0.08, py = std::max(yhi - ylo, 1e-3) * 0.1;
    xlo -= px, xhi += px, ylo -= py, yhi += py;
  }
  auto X = [&](double v) { return x0 + w * (fx(v) - xlo) / (xhi - xlo); };
  auto Y = [&](double v) { return y0 - h * (v - ylo) / (yhi - ylo); };
  s += line(x0, y0, x0 + w, y0) + line(x0, y0, x0, y0 - h);
  if (circle > 0) {
    s += "<ellipse cx=\"" + num(X(0), 1) + "\" cy=\"" + num(Y(0), 1) + "\" rx=\"" + num(w * circle / (xhi - xlo), 1) + "\" ry=\"" +
         num(h * circle / (yhi - ylo), 1) + "\" fill=\"none\" stroke=\"#c44\" stroke-dasharray=\"4 3\"/>\n";
    s += line(X(0), y0, X(0), y0 - h, "#ccc") + line(x0, Y(0), x0 + w, Y(0), "#ccc");
  }
  const double tx = niceStep(xhi - xlo, 5), ty = niceStep(yhi - ylo, 5);
  for (double v = std::ceil(xlo / tx) * tx; v <= xhi + 1e-12; v += tx) {
    const double x = x0 + w * (v - xlo) / (xhi - xlo);
    s += line(x, y0, x, y0 + 4) + text(x, y0 + 16, log_x ? num(std::pow(10.0, v), v < 0 ? 2 : 0) : num(v, tx < 1 ? (tx < 0.1 ? 2 : 1) : 0), "middle");
  }
  for (double v = std::ceil(ylo / ty) * ty; v <= yhi + 1e-12; v += ty)
    s += line(x0 - 4, Y(v), x0, Y(v)) + text(x0 - 6, Y(v) + 4, num(v, ty < 1 ? (ty < 0.1 ? 2 : 1) : 0), "end");
  for (const Point& p : pts) {
    s += "<circle cx=\"" + num(X(p.x), 1) + "\" cy=\"" + num(Y(p.y), 1) + "\" r=\"3.5\" fill=\"#4878a8\" fill-opacity=\"0.7\"><title>" +
         esc(p.label.empty() ? num(p.x, 2) + ", " + num(p.y, 2) : p.label) + "</title></circle>\n";
    if (!p.label.empty()) s += text(X(p.x) + 6, Y(p.y) - 5, p.label, "start", "font-size=\"10\"");
  }
  s += text(x0 + w / 2, y0 + 34, xaxis, "middle") +
       text(16, y0 - h / 2, yaxis, "middle", ("transform=\"rotate(-90 16 " + num(y0 - h / 2, 0) + ")\"").c_str());
  return s + "</svg>\n";
}

// ---- the report --------------------------------------------------------------------------------

struct Section {
  std::string title, html, md;  ///< html: tables and figures; md: the same tables, figures by file
};

class Builder {
 public:
  explicit Builder(fs::path figures) : figures_(std::move(figures)) {}
  void section(const std::string& title) { sections_.push_back({title, "", ""}); }
  void para(const std::string& s) {
    cur().html += "<p>" + esc(s) + "</p>\n";
    cur().md += s + "\n\n";
  }
  /// A table; cells with a key get data-key (the test reads them back from the rendered page).
  void table(const std::vector<std::string>& head, const std::vector<std::vector<std::pair<std::string, std::string>>>& rows) {
    std::string h = "<table><tr>", m = "|";
    for (const auto& c : head) h += "<th>" + esc(c) + "</th>", m += " " + c + " |";
    h += "</tr>\n";
    m += "\n|";
    for (size_t i = 0; i < head.size(); ++i) m += "---|";
    m += "\n";
    for (const auto& r : rows) {
      h += "<tr>";
      m += "|";
      for (const auto& [value, key] : r) {
        h += key.empty() ? "<td>" + esc(value) + "</td>" : "<td data-key=\"" + esc(key) + "\">" + esc(value) + "</td>";
        m += " " + value + " |";
      }
      h += "</tr>\n";
      m += "\n";
    }
    cur().html += h + "</table>\n";
    cur().md += m + "\n";
  }
  void figure(const std::string& id, const std::string& svg, const std::string& caption) {
    cur().html += "<figure data-plot=\"" + id + "\">" + svg + "<figcaption>" + esc(caption) + "</figcaption></figure>\n";
    files_[id + ".svg"] = svg;
    cur().md += "![" + caption + "](report_figures/" + id + ".svg)\n\n*" + caption + "*\n\n";
  }
  const std::vector<Section>& sections() const { return sections_; }
  const std::map<std::string, std::string>& files() const { return files_; }

 private:
  Section& cur() { return sections_.back(); }
  fs::path figures_;
  std::vector<Section> sections_;
  std::map<std::string, std::string> files_;
};

std::string pct(double v) { return num(100 * v, 1) + "%"; }
std::string interval(const json& ci) { return "[" + num(100 * ci.at(0).get<double>(), 1) + ", " + num(100 * ci.at(1).get<double>(), 1) + "]"; }

void campaignSections(Builder& b, const json& s, const fs::path& jsonl) {
  // Stream the trials: the cycle times of successes and the placed objects' offsets.
  std::vector<double> cycles;
  std::vector<Point> offsets;
  long picks = 0;
  std::ifstream in(jsonl);
  long n = 0;
  for (std::string line; std::getline(in, line);) {
    ++n;
    json t;
    try {
      t = json::parse(line);
    } catch (const std::exception& e) {
      throw InputError(jsonl.string() + ":" + std::to_string(n), std::string("not JSON: ") + e.what());
    }
    if (t.value("success", false)) cycles.push_back(t.at("cycle").at("total_time").get<double>());
    for (const json& p : t.value("picks", json::array())) {
      if (!p.value("at_target", false) || !p.contains("offset")) continue;
      ++picks;
      offsets.push_back({1000 * p.at("offset").at(0).get<double>(), 1000 * p.at("offset").at(1).get<double>(), ""});
    }
  }

  b.section("Yields");
  const auto& fp = s.at("first_pass_yield");
  const auto& ov = s.at("overall_yield");
  b.table({"metric", "value", "95% interval (Wilson)", "count"},
          {{{"first-pass yield", ""}, {pct(fp.at("value")), "first_pass_yield"}, {interval(fp.at("ci95")), ""},
            {"without a recovery", ""}},
           {{"overall yield", ""}, {pct(ov.at("value")), "overall_yield"}, {interval(ov.at("ci95")), ""},
            {std::to_string(s.at("successes").get<long>()) + " / " + std::to_string(s.at("trials").get<long>()), "successes_of_trials"}},
           {{"recovery rate", ""},
            {s.at("recovery_rate").get<double>() < 0 ? "n/a" : pct(s.at("recovery_rate")), "recovery_rate"},
            {"", ""},
            {std::to_string(s.at("recoveries_needed").get<long>()) + " needed one", ""}}});
  b.table({"metric", "value"},
          {{{"mean cycle time ± std (max)", ""},
            {num(s.at("cycle_time").at("mean"), 2) + " ± " + num(s.at("cycle_time").at("std"), 2) + " s (" + num(s.at("cycle_time").at("max"), 2) + " s)",
             "cycle_time"}},
           {{"throughput", ""}, {num(s.at("throughput_per_hour"), 0) + " picks/h", "throughput_per_hour"}},
           {{"place error mean / max", ""},
            {num(s.at("place_position_error_mm").at("mean"), 2) + " / " + num(s.at("place_position_error_mm").at("max"), 2) + " mm",
             "place_position_error_mm"}},
           {{"collision events", ""}, {std::to_string(s.at("collision_events").get<long>()), "collision_events"}},
           s.value("goal", "pick_one") == "clear_bin"
               ? std::vector<std::pair<std::string, std::string>>{{"objects placed of spawned (object yield)", ""},
                                                                 {std::to_string(s.at("objects_placed").get<long>()) + " of " +
                                                                      std::to_string(s.at("objects_spawned").get<long>()) + " (" +
                                                                      pct(s.at("object_yield").at("value")) + ", " +
                                                                      interval(s.at("object_yield").at("ci95")) + ")",
                                                                  "objects"}}
               : std::vector<std::pair<std::string, std::string>>{{"objects placed (one a trial asked)", ""},
                                                                 {std::to_string(s.at("objects_placed").get<long>()) + "; " +
                                                                      std::to_string(s.at("objects_left_in_bin").get<long>()) +
                                                                      " others stay in the bins, as asked",
                                                                  "objects"}},
           {{"timeouts / crashes / hangs / unstable", ""},
            {std::to_string(s.at("timeouts").get<long>()) + " / " + std::to_string(s.value("crashes", 0L)) + " / " +
                 std::to_string(s.value("hangs", 0L)) + " / " + std::to_string(s.at("sim_unstable").get<long>()),
             "harness_failures"}}});

  if (s.contains("clutter_by_grade") && !s.at("clutter_by_grade").empty()) {
    b.section("Clutter removal");
    b.para("The clutter-removal protocol's figures (VGN, GIGA): grasp success rate, the attempts (closings of the fingers on a "
           "chosen grasp) whose object was released in the tray; declutter rate, the objects released in the tray of those in the "
           "bins. Per shape grade of the generated objects, with Wilson 95% intervals.");
    auto cells = [&](const json& r, const std::string& id) -> std::vector<std::pair<std::string, std::string>> {
      if (r.at("n").get<long>() == 0) return {{"n/a", id}, {"", ""}, {"0", ""}};
      return {{pct(r.at("value")), id}, {interval(r.at("ci95")), ""}, {std::to_string(r.at("k").get<long>()) + " / " + std::to_string(r.at("n").get<long>()), ""}};
    };
    std::vector<std::vector<std::pair<std::string, std::string>>> rows;
    auto row = [&](const std::string& name, const json& g) {
      std::vector<std::pair<std::string, std::string>> cols{{name, ""}};
      for (const auto& c : cells(g.at("grasp_success_rate"), "grasp_success_rate." + name)) cols.push_back(c);
      for (const auto& c : cells(g.at("declutter_rate"), "declutter_rate." + name)) cols.push_back(c);
      rows.push_back(cols);
    };
    row("all", s);
    for (const json& g : s.at("clutter_by_grade")) row(g.at("grade").get<std::string>(), g);
    b.table({"grade", "grasp success", "95% interval", "in tray / attempts", "declutter", "95% interval", "in tray / objects"}, rows);
    std::string results;
    for (const auto& [result, count] : s.at("attempt_results").items())
      results += (results.empty() ? "" : ", ") + result + " " + std::to_string(count.get<long>());
    b.para("Attempts by result: " + (results.empty() ? std::string("none") : results) + ".");
  }

  b.section("Cycle time");
  b.figure("cycle_histogram", histogram("cycle_histogram", cycles, "cycle time of successful trials [s]"),
           "Cycle time of the " + std::to_string(cycles.size()) + " successful trials (the source's breakdown summed).");
  std::vector<Bar> parts;
  const std::pair<const char*, const char*> names[] = {
      {"perception_time", "perception (compute)"}, {"plan_pick_time", "plan pick (compute)"},
      {"execute_pick_time", "execute pick (sim)"},   {"plan_place_time", "plan place (compute)"},
      {"execute_place_time", "execute place (sim)"}, {"return_home_time", "return home (plan + sim)"}};
  for (const auto& [k, label] : names) {
    const double v = s.at("mean_time_breakdown").value(k, 0.0);
    parts.push_back({label, v, NAN, NAN, v < 0.1 ? num(1000 * v, 1) + " ms" : num(v, 2) + " s"});
  }
  b.figure("stage_breakdown", barChart("stage_breakdown", parts, "mean over successful trials [s]"),
           "Where a successful trial's cycle goes, stage by stage.");

  b.section("Failures");
  std::vector<Bar> stages;
  for (const auto& [stage, count] : s.at("failure_stages").items())
    stages.push_back({stage, count.get<double>(), NAN, NAN, std::to_string(count.get<long>())});
  if (stages.empty()) b.para("No trial failed.");
  else b.figure("failure_stages", barChart("failure_stages", stages, "failed trials"), "Failed trials by the stage that failed.");

  b.section("Place accuracy");
  b.figure("place_scatter",
           scatter("place_scatter", offsets, "x offset on the tray [mm]", "y offset [mm]", true, 5.0),
           "Where each of the " + std::to_string(picks) + " objects let go of over its target came to rest, relative to the "
           "target (world x, y; the dashed circle is the 5 mm tolerance).");

  if (!s.at("faults").empty()) {
    b.section("Recovery per fault kind");
    std::vector<Bar> bars;
    std::vector<std::vector<std::pair<std::string, std::string>>> rows;
    for (const json& f : s.at("faults")) {
      const double r = f.at("recovery").get<double>();
      const std::string kind = f.at("kind");
      if (r >= 0) bars.push_back({kind, 100 * r, 100 * f.at("ci95").at(0).get<double>(), 100 * f.at("ci95").at(1).get<double>(), pct(r)});
      rows.push_back({{kind, ""}, {std::to_string(f.at("injected").get<long>()), ""}, {std::to_string(f.at("detected").get<long>()), ""},
                      {r < 0 ? "none judged" : pct(r), "recovery." + kind},
                      {r < 0 ? "" : interval(f.at("ci95")), ""},
                      {f.at("mttr_mean").get<double>() < 0 ? "" : num(f.at("mttr_mean"), 2) + " s", ""}});
    }
    b.table({"fault", "injected", "detected", "recovered (or correctly given up)", "95% interval", "MTTR"}, rows);
    b.figure("fault_recovery", barChart("fault_recovery", bars, "recovered or correctly given up [%] (whiskers: Wilson 95%)", 100),
             "Recovery per injected fault kind.");
    b.para("MTBF: " + (s.at("mtbf").get<double>() < 0 ? std::string("no unrecovered failure") : num(s.at("mtbf"), 1) + " s simulated") +
           "; protective stops: " + std::to_string(s.at("protective_stops").get<long>()) + ".");
  }
}

void ikSections(Builder& b, const json& j) {
  b.section("IK solvers (ik-bench)");
  b.para("Command: " + j.value("command", std::string("?")) + "; seed " + std::to_string(j.value("seed", 0)) + "; " +
         std::to_string(j.value("poses_per_set", 0)) + " poses per set; machine: " + j.at("machine").value("cpu", std::string("?")) +
         ", " + std::to_string(j.at("machine").value("cores", 0)) + " cores.");
  for (const auto& [set, solvers] : j.at("sets").items()) {
    std::vector<Point> pts;
    std::vector<std::vector<std::pair<std::string, std::string>>> rows;
    for (const json& r : solvers) {
      pts.push_back({r.at("time_us").at("mean").get<double>(), 100 * r.at("success").get<double>(), r.at("solver").get<std::string>()});
      rows.push_back({{r.at("solver"), ""}, {pct(r.at("success")), ""}, {interval(r.at("ci95")), ""}, {num(r.at("time_us").at("mean"), 1), ""},
                      {num(r.at("time_us").at("p99"), 1), ""}});
    }
    b.table({"solver (" + set + ")", "success", "95% interval", "mean µs", "p99 µs"}, rows);
    b.figure("ik_" + set, scatter("ik_" + set, pts, "mean time per solve [µs] (log)", "success [%]", false, 0, true),
             "IK solvers on the '" + set + "' poses: success against mean time.");
  }
}

void planSections(Builder& b, const json& j) {
  b.section("Planners and collision checkers (plan-bench)");
  b.para("Command: " + j.value("command", std::string("?")) + "; seed " + std::to_string(j.value("seed", 0)) + "; " +
         std::to_string(j.value("problems", 0)) + " problems (" + j.value("problem_set", std::string("?")) + "); machine: " +
         j.at("machine").value("cpu", std::string("?")) + ", " + std::to_string(j.at("machine").value("cores", 0)) + " cores.");
  std::vector<Point> pts;
  std::vector<std::vector<std::pair<std::string, std::string>>> rows;
  for (const json& c : j.at("combinations")) {
    const std::string name = c.at("planner").get<std::string>() + " + " + c.at("checker").get<std::string>();
    pts.push_back({c.at("plan_ms").at("mean").get<double>(), 100 * c.at("success").get<double>(), name});
    rows.push_back({{c.at("planner"), ""}, {c.at("checker"), ""}, {pct(c.at("success")), ""}, {interval(c.at("ci95")), ""},
                    {num(c.at("plan_ms").at("mean"), 1), ""}, {num(c.at("path_length_mean"), 2), ""}});
  }
  b.table({"planner", "checker", "success", "95% interval", "plan ms mean", "path length (rad)"}, rows);
  b.figure("plan_success_time", scatter("plan_success_time", pts, "mean planning time [ms] (log)", "success [%]", false, 0, true),
           "Planners × collision checkers on the same problems: success against mean planning time.");
}

// ---- a sweep: yield, recovery and cycle time against each factor ---------------------------------

struct Pool {
  long trials = 0, successes = 0, needed = 0, recovered = 0;
  double cycle_sum = 0;  ///< over successes
};

void addCell(Pool& p, const json& s) {
  const long n = s.at("trials").get<long>(), k = s.at("successes").get<long>(), need = s.at("recoveries_needed").get<long>();
  p.trials += n;
  p.successes += k;
  p.needed += need;
  if (need > 0) p.recovered += std::lround(s.at("recovery_rate").get<double>() * need);
  if (k > 0) p.cycle_sum += s.at("cycle_time").at("mean").get<double>() * k;
}

std::string settingsText(const json& settings, const json& factors) {
  std::string t;  // in the factors' order
  for (const json& f : factors) {
    const std::string k = f.at("key").get<std::string>();
    t += (t.empty() ? "" : ", ") + k + " = " + settings.at(k).get<std::string>();
  }
  return t;
}

/// The sections of a sweep's report; returns the first cell's summary (for the machine line).
json sweepSections(Builder& b, const fs::path& dir, const json& sweep) {
  std::vector<json> summaries;
  for (const json& c : sweep.at("cells")) {
    const fs::path sp = dir / c.at("dir").get<std::string>() / "summary.json";
    if (!fs::exists(sp))
      throw InputError(sp.string(), "not found: the sweep has not finished this cell (run the same command again to resume)");
    summaries.push_back(readJson(sp));
  }
  // The cells' own summaries say how many trials each holds (a cell resumed with another --trials
  // differs from sweep.json's count): the page counts those, and says so when they differ.
  long min_trials = -1, max_trials = -1;
  for (const json& s : summaries) {
    const long n = s.at("trials").get<long>();
    min_trials = min_trials < 0 ? n : std::min(min_trials, n);
    max_trials = std::max(max_trials, n);
  }
  b.section("Cells");
  if (min_trials == max_trials)
    b.para("Every cell runs the same " + std::to_string(min_trials) + " trial indices of seed " +
           std::to_string(sweep.at("seed").get<unsigned long>()) +
           " (the same scenes and random streams wherever a factor leaves them alone); each cell's folder is a campaign's "
           "results folder of its own (its report, its gate).");
  else
    b.para("Warning: the cells hold different numbers of trials (" + std::to_string(min_trials) + " to " +
           std::to_string(max_trials) + ", seed " + std::to_string(sweep.at("seed").get<unsigned long>()) +
           "), so they do not all see the same scenes and the pooled plots mix trial sets: run the sweep again with one "
           "--trials to even them. Each cell's folder is a campaign's results folder of its own.");
  std::vector<std::vector<std::pair<std::string, std::string>>> rows;
  for (size_t i = 0; i < summaries.size(); ++i) {
    const json& c = sweep.at("cells").at(i);
    const json& s = summaries[i];
    const double rr = s.at("recovery_rate").get<double>();
    rows.push_back({{c.at("dir").get<std::string>(), ""},
                    {settingsText(c.at("settings"), sweep.at("factors")), ""},
                    {std::to_string(s.at("trials").get<long>()), ""},
                    {pct(s.at("overall_yield").at("value").get<double>()), "cell" + std::to_string(i) + ".yield"},
                    {interval(s.at("overall_yield").at("ci95")), ""},
                    {rr < 0 ? "-" : pct(rr), ""},
                    {s.at("successes").get<long>() > 0 ? num(s.at("cycle_time").at("mean").get<double>(), 2) + " s" : "-", ""}});
  }
  b.table({"cell", "settings", "trials", "overall yield", "95% CI", "recovery", "mean cycle"}, rows);

  size_t fi = 0;
  for (const json& f : sweep.at("factors")) {
    const std::string key = f.at("key").get<std::string>();
    b.section("Against " + key);
    b.para("Each value pools every cell with it (the other factors' cells alike: a full grid), so each bar holds " +
           std::to_string(summaries.size() / f.at("values").size()) + " cells' trials; whiskers are Wilson 95% intervals.");
    std::vector<Bar> yield, recovery, cycle;
    for (const json& v : f.at("values")) {
      Pool p;
      for (size_t i = 0; i < summaries.size(); ++i)
        if (sweep.at("cells").at(i).at("settings").at(key) == v) addCell(p, summaries[i]);
      const std::string label = key.substr(key.rfind('.') + 1) + " = " + v.get<std::string>();
      const auto ci = wilson95(p.successes, p.trials);
      yield.push_back({label, p.trials ? double(p.successes) / p.trials : 0, ci.first, ci.second,
                       std::to_string(p.successes) + "/" + std::to_string(p.trials) + " = " +
                           pct(p.trials ? double(p.successes) / p.trials : 0)});
      if (p.needed > 0) {
        const auto rc = wilson95(p.recovered, p.needed);
        recovery.push_back({label, double(p.recovered) / p.needed, rc.first, rc.second,
                            std::to_string(p.recovered) + "/" + std::to_string(p.needed) + " = " + pct(double(p.recovered) / p.needed)});
      } else {
        recovery.push_back({label, 0, NAN, NAN, "none needed"});
      }
      const double cm = p.successes ? p.cycle_sum / p.successes : 0;
      cycle.push_back({label, cm, NAN, NAN, p.successes ? num(cm, 2) + " s" : "no success"});
    }
    const std::string id = "sweep" + std::to_string(fi++);
    b.figure(id + "_yield", barChart(id + "_yield", yield, "overall yield", 1.0), "Overall yield against " + key);
    b.figure(id + "_recovery", barChart(id + "_recovery", recovery, "recovery rate (recovered / recoveries needed)", 1.0),
             "Recovery against " + key);
    b.figure(id + "_cycle", barChart(id + "_cycle", cycle, "mean cycle time of successes (s)"), "Cycle time against " + key);
  }
  return summaries.front();
}


}  // namespace

std::string writeReport(const ReportOptions& o) {
  const fs::path dir(o.results_dir);
  const bool is_sweep = !fs::exists(dir / "summary.json") && fs::exists(dir / "sweep.json");
  const json sweep = is_sweep ? readJson(dir / "sweep.json") : json();
  json s = is_sweep ? json() : readJson(dir / "summary.json");
  if (!is_sweep && !fs::exists(dir / "trials.jsonl")) throw InputError((dir / "trials.jsonl").string(), "not found");
  json ik, plan;
  if (!o.ik_bench.empty()) ik = readJson(fs::path(o.ik_bench) / "ik_bench.json");
  if (!o.plan_bench.empty()) plan = readJson(fs::path(o.plan_bench) / "plan_bench.json");

  Builder b(dir / "report_figures");
  try {
    if (is_sweep) {
      s = sweepSections(b, dir, sweep);
      // The page's facts are the sweep's; the machine is the first cell's.
      s["experiment"] = "sweep of " + sweep.at("experiment").get<std::string>();
      std::string factors;
      for (const json& f : sweep.at("factors")) factors += (factors.empty() ? "" : " x ") + f.at("key").get<std::string>();
      s["tree"] = s.value("tree", std::string("?")) + " · factors " + factors + " · " + std::to_string(sweep.at("cells").size()) + " cells";
      long trials = 0;
      for (const json& c : sweep.at("cells"))
        trials += readJson(dir / c.at("dir").get<std::string>() / "summary.json").at("trials").get<long>();
      s["trials"] = trials;
    } else {
      campaignSections(b, s, dir / "trials.jsonl");
    }
    if (!ik.is_null()) ikSections(b, ik);
    if (!plan.is_null()) planSections(b, plan);
  } catch (const json::exception& e) {
    throw InputError(dir.string(), std::string("a results file lacks what the report reads: ") + e.what());
  }

  if (!s.contains("environment") || !s.contains("trials")) throw InputError((dir / "summary.json").string(), "not a campaign summary");
  const json& env = s.at("environment");
  const std::string title = "Mini-Manip Bench: " + s.value("experiment", std::string("campaign"));
  const std::string facts = "Command: " + s.value("command", std::string("?")) + " · seed " + std::to_string(s.value("seed", 0UL)) +
                            " · " + s.value("hardware", std::string("?")) + " · tree " + s.value("tree", std::string("?")) +
                            " · " + std::to_string(s.at("trials").get<long>()) + " trials";
  const std::string machine = "Machine: " + env.value("cpu", std::string("?")) + ", " + std::to_string(env.value("cores", 0L)) +
                              " cores, host " + env.value("host", std::string("?")) + ", " + std::to_string(env.value("jobs", 0L)) +
                              " worker processes · minimanip " + env.value("minimanip", std::string("?")) + ", MuJoCo " +
                              env.value("mujoco", std::string("?")) + ", OMPL " + env.value("ompl", std::string("?")) + ", " +
                              env.value("compiler", std::string("?"));
  std::string html =
      "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>" + esc(title) +
      "</title>\n<style>body{font-family:sans-serif;max-width:60em;margin:2em auto;color:#222}"
      "table{border-collapse:collapse;margin:0.5em 0 1em}td,th{border:1px solid #bbb;padding:3px 8px;text-align:left}"
      "th{background:#eee}figure{margin:0.5em 0 1.5em}figcaption{font-size:0.9em;color:#555}.facts{font-size:0.9em;color:#444}"
      "</style></head>\n<body>\n<h1>" + esc(title) + "</h1>\n<p class=\"facts\">" + esc(facts) + "<br>" + esc(machine) + "</p>\n";
  std::string md = "# " + title + "\n\n" + facts + "  \n" + machine + "\n\n";
  for (const Section& sec : b.sections()) {
    html += "<h2>" + esc(sec.title) + "</h2>\n" + sec.html;
    md += "## " + sec.title + "\n\n" + sec.md;
  }
  html += "</body></html>\n";

  createDirectories(dir / "report_figures");
  for (const auto& [name, svg] : b.files()) writeFileAtomically(dir / "report_figures" / name, "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n" + svg);
  writeFileAtomically(dir / "report.md", md);
  writeFileAtomically(dir / "report.html", html);
  return (dir / "report.html").string();
}

}  // namespace mm

// Helpers of the end-to-end tests: the minimanip binary run as a user would, temporary folders,
// trials.jsonl read back.
#pragma once
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace mm::testing_cli {

namespace fs = std::filesystem;
using json = nlohmann::json;

struct RunResult {
  int code = -1;
  std::string out;  // stdout and stderr
};

inline RunResult runMinimanip(const std::string& args) {
  RunResult r;
  const std::string cmd = std::string(MINIMANIP_BINARY) + " " + args + " 2>&1";
  FILE* p = popen(cmd.c_str(), "r");
  char buf[4096];
  while (size_t n = fread(buf, 1, sizeof buf, p)) r.out.append(buf, n);
  const int status = pclose(p);
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

class TempDir {
 public:
  TempDir() {
    path_ = fs::temp_directory_path() / ("mm_test_" + std::to_string(getpid()) + "_" + std::to_string(counter_++));
    fs::create_directories(path_);
  }
  ~TempDir() { fs::remove_all(path_); }
  const fs::path& path() const { return path_; }
  std::string file(const std::string& name, const std::string& text) const {
    std::ofstream((path_ / name).string()) << text;
    return (path_ / name).string();
  }

 private:
  fs::path path_;
  static inline int counter_ = 0;
};

inline std::vector<json> readTrials(const fs::path& dir) {
  std::vector<json> v;
  std::ifstream in(dir / "trials.jsonl");
  for (std::string line; std::getline(in, line);) v.push_back(json::parse(line));
  std::sort(v.begin(), v.end(), [](const json& a, const json& b) { return a["trial"] < b["trial"]; });
  return v;
}

// Everything but wall-clock figures and how many worker processes a trial took.
inline json outcomeFields(json t) {
  t.erase("cycle");
  t.erase("compute_time");
  t.erase("attempts");
  for (auto& s : t["stages"]) s.erase("compute_seconds");
  for (auto& f : t["faults"]) f.erase("mttr");  // counts compute wall time
  for (auto& c : t["external_calls"])
    for (const char* k : {"write_seconds", "answer_seconds"}) c.erase(k);
  for (auto& v : t["pose_views"]) v.erase("seconds");
  return t;
}

inline int shellOut(const std::string& cmd, std::string& out) {
  FILE* p = popen(cmd.c_str(), "r");
  char buf[4096];
  out.clear();
  while (size_t n = fread(buf, 1, sizeof buf, p)) out.append(buf, n);
  const int status = pclose(p);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

/// Loads `html` in headless Chromium (Debian's chromium), lets it lay the page out and returns the
/// DOM it dumps, whose body carries data-plots-drawn: the SVG plots drawn with a size and marks.
/// Empty when Chromium fails.
inline std::string renderInChromium(const fs::path& html_file, const fs::path& scratch) {
  std::ifstream in(html_file);
  std::string html((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const size_t body = html.find("</body>");
  if (body == std::string::npos) return "";
  html.replace(body, 7,
               "<script>window.addEventListener('load',()=>{let n=0;for(const s of document.querySelectorAll('svg.plot')){"
               "const b=s.getBBox();if(b.width>100&&b.height>50&&s.querySelectorAll('rect,circle,line').length>3)n++;}"
               "document.body.setAttribute('data-plots-drawn',n);});</script></body>");
  const fs::path probe = scratch / "probe.html";
  std::ofstream(probe) << html;
  std::string dom;
  const std::string chromium = "chromium --headless --no-sandbox --disable-gpu --run-all-compositor-stages-before-draw "
                               "--virtual-time-budget=5000 ";
  if (shellOut(chromium + "--dump-dom file://" + probe.string() + " 2>/dev/null", dom) != 0) return "";
  return dom;
}

}  // namespace mm::testing_cli

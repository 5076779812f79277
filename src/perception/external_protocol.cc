#include "perception/external_protocol.h"

#include <cmath>
#include <nlohmann/json.hpp>
#include <sstream>
#include <stdexcept>

#include "core/file_io.h"
#include "core/utf8.h"

namespace mm {

namespace {

using ojson = nlohmann::ordered_json;
using json = nlohmann::json;

constexpr double kFarthest = 100.0;   // [m] a pose farther than this from its frame is no cell's
constexpr size_t kMostEntries = 10000;  // grasps or objects in one answer

ojson matrixJson(const Pose& T) {
  ojson rows = ojson::array();
  for (int r = 0; r < 4; ++r) {
    ojson row = ojson::array();
    for (int c = 0; c < 4; ++c) row.push_back(T.matrix()(r, c));
    rows.push_back(row);
  }
  return rows;
}

std::string numberText(double v) {
  std::ostringstream o;
  o << v;
  return o.str();
}

// The start of a line the child sent, for a reason (a record's field: valid UTF-8, whatever it sent).
std::string shortText(const std::string& s) { return escapeInvalidUtf8(s.size() <= 80 ? s : s.substr(0, 77) + "..."); }

bool finiteNumber(const json& j, double& out) {
  if (!j.is_number()) return false;
  out = j.get<double>();
  return std::isfinite(out);
}

// A 4 x 4 rigid motion: finite, the last row (0 0 0 1), the rotation orthonormal and right-handed.
bool readPose(const json& j, Pose& T, std::string& why) {
  if (!j.is_array() || j.size() != 4) {
    why = "\"T\" is not a 4 x 4 matrix (a list of 4 rows)";
    return false;
  }
  Eigen::Matrix4d m;
  for (int r = 0; r < 4; ++r) {
    const json& row = j[static_cast<size_t>(r)];
    if (!row.is_array() || row.size() != 4) {
      why = "\"T\" row " + std::to_string(r) + " is not 4 numbers";
      return false;
    }
    for (int c = 0; c < 4; ++c)
      if (!finiteNumber(row[static_cast<size_t>(c)], m(r, c))) {
        why = "\"T\" has a value that is not a finite number (row " + std::to_string(r) + ", column " + std::to_string(c) + ")";
        return false;
      }
  }
  if (m.topRightCorner<3, 1>().norm() > kFarthest) {
    why = "\"T\" places it more than 100 m away";
    return false;
  }
  if ((m.row(3) - Eigen::RowVector4d(0, 0, 0, 1)).cwiseAbs().maxCoeff() > 1e-6) {
    why = "\"T\"'s last row is not (0 0 0 1)";
    return false;
  }
  const Mat3 R = m.topLeftCorner<3, 3>();
  if ((R.transpose() * R - Mat3::Identity()).cwiseAbs().maxCoeff() > 1e-4 || R.determinant() < 0) {
    why = "\"T\"'s rotation is not a rotation (not orthonormal within 1e-4, or a reflection)";
    return false;
  }
  // Re-orthonormalized, so that what is within the tolerance is a rotation exactly.
  const Eigen::JacobiSVD<Mat3> svd(R, Eigen::ComputeFullU | Eigen::ComputeFullV);
  T = Pose::Identity();
  T.linear() = svd.matrixU() * svd.matrixV().transpose();
  T.translation() = m.topRightCorner<3, 1>();
  return true;
}

}  // namespace

bool parseExternalFrame(const std::string& name, ExternalFrame& out) {
  if (name == "camera") out = ExternalFrame::kCamera;
  else if (name == "world") out = ExternalFrame::kWorld;
  else return false;
  return true;
}

std::string requestLine(const ExternalRequest& r) {
  ojson j;
  j["protocol"] = kExternalProtocolVersion;
  j["id"] = r.id;
  j["want"] = r.want == ExternalWant::kObjects ? "objects" : "grasps";
  j["trial"] = r.trial;
  j["seed"] = r.seed;
  auto path = [](const std::filesystem::path& p) { return p.empty() ? ojson(nullptr) : ojson(p.string()); };
  j["images"] = {{"depth", path(r.depth)}, {"rgb", path(r.rgb)}, {"labels", path(r.labels)}};
  const CameraModel& c = r.camera;
  j["camera"] = {{"width", c.width}, {"height", c.height}, {"fx", c.fx}, {"fy", c.fy}, {"cx", c.cx}, {"cy", c.cy},
                 {"T_world_camera", matrixJson(c.T_world_camera)}};
  j["region"] = {{"T_world_region", matrixJson(r.T_world_region)}, {"half_extents", {r.region_half.x(), r.region_half.y(), r.region_half.z()}}};
  const ExternalGripper& g = r.gripper;
  j["gripper"] = {{"stroke", g.stroke},
                  {"finger_thickness", g.finger_thickness},
                  {"pad_half_width", g.pad_half_width},
                  {"pad_z_min", g.pad_z_min},
                  {"pad_z_max", g.pad_z_max},
                  {"hand_back", g.hand_back},
                  {"hand_half_thickness", g.hand_half_thickness},
                  {"hand_half_width", g.hand_half_width},
                  {"finger_margin", g.finger_margin}};
  j["oracle"] = r.oracle_segmentation ? ojson("segmentation") : ojson(nullptr);
  return j.dump();
}

bool parseAnswer(const std::string& line, const ExternalRequest& request, ExternalAnswer& out, std::string& why) {
  out = ExternalAnswer{};
  const json j = json::parse(line, nullptr, false);
  if (j.is_discarded()) {
    why = "not JSON: \"" + shortText(line) + "\"";
    return false;
  }
  if (!j.is_object()) {
    why = "not a JSON object: \"" + shortText(line) + "\"";
    return false;
  }
  const auto version = j.find("protocol");
  if (version == j.end() || !version->is_number_integer() || version->get<int64_t>() != kExternalProtocolVersion) {
    why = "\"protocol\" is " + (version == j.end() ? std::string("missing") : version->dump()) + ", expected " +
          std::to_string(kExternalProtocolVersion);
    return false;
  }
  const auto id = j.find("id");
  if (id == j.end() || !id->is_number_unsigned() || id->get<uint64_t>() != request.id) {
    why = "answers request " + (id == j.end() ? std::string("(no id)") : id->dump()) + ", expected " + std::to_string(request.id);
    return false;
  }
  if (const auto e = j.find("error"); e != j.end()) {
    if (!e->is_string() || e->get<std::string>().empty()) {
      why = "\"error\" is not a non-empty string";
      return false;
    }
    out.error = e->get<std::string>();
    return true;
  }
  const auto f = j.find("frame");
  ExternalFrame frame;
  if (f == j.end() || !f->is_string() || !parseExternalFrame(f->get<std::string>(), frame)) {
    why = "\"frame\" is " + (f == j.end() ? std::string("missing") : f->dump()) + ", expected \"camera\" or \"world\"";
    return false;
  }
  out.frame = frame;
  const Pose T_world_frame = frame == ExternalFrame::kCamera ? request.camera.T_world_camera : Pose::Identity();
  const bool objects = request.want == ExternalWant::kObjects;
  const char* list = objects ? "objects" : "grasps";
  const auto items = j.find(list);
  if (items == j.end() || !items->is_array()) {
    why = std::string("\"") + list + "\" is missing or not a list (the request wanted " + list + ")";
    return false;
  }
  if (items->size() > kMostEntries) {
    why = std::string("\"") + list + "\" has " + std::to_string(items->size()) + " entries, more than " + std::to_string(kMostEntries);
    return false;
  }
  for (size_t k = 0; k < items->size(); ++k) {
    const json& g = (*items)[k];
    const std::string where = std::string(list) + "[" + std::to_string(k) + "]: ";
    if (!g.is_object() || !g.contains("T")) {
      why = where + "not an object with \"T\"";
      return false;
    }
    Pose T;
    if (!readPose(g["T"], T, why)) {
      why = where + why;
      return false;
    }
    double score = 0;
    if (!g.contains("score") || !finiteNumber(g["score"], score)) {
      why = where + "\"score\" is missing or not a finite number";
      return false;
    }
    if (objects) {
      if (!g.contains("name") || !g["name"].is_string()) {
        why = where + "\"name\" is missing or not a string";
        return false;
      }
      out.objects.push_back({escapeInvalidUtf8(g["name"].get<std::string>()), T_world_frame * T, score});
    } else {
      double opening = 0;
      if (!g.contains("opening") || !finiteNumber(g["opening"], opening) || opening <= 0 || opening > request.gripper.stroke + 1e-9) {
        why = where + "\"opening\" is " + (g.contains("opening") ? g["opening"].dump() : std::string("missing")) + ", expected (0, " +
              numberText(request.gripper.stroke) + "] m (the stroke)";
        return false;
      }
      out.grasps.push_back({T_world_frame * T, opening, score});
    }
  }
  return true;
}

void writeNpy(const std::filesystem::path& path, const std::string& dtype, const std::vector<size_t>& shape, const void* data, size_t bytes) {
  size_t items = 1;
  for (size_t n : shape) items *= n;
  const size_t digits = dtype.find_last_not_of("0123456789") + 1;
  const size_t item_size = digits < dtype.size() ? std::stoul(dtype.substr(digits)) : 0;
  if (item_size == 0 || items * item_size != bytes)
    throw std::invalid_argument("writeNpy: " + std::to_string(bytes) + " bytes for " + std::to_string(items) + " items of " + dtype);
  std::ostringstream dict;
  dict << "{'descr': '" << dtype << "', 'fortran_order': False, 'shape': (";
  for (size_t k = 0; k < shape.size(); ++k) dict << shape[k] << (shape.size() == 1 || k + 1 < shape.size() ? ", " : "");
  dict << "), }";
  // Magic (6), version (2), header length (2), then the dictionary padded with spaces and ended by a
  // newline so that the data starts on a multiple of 64 bytes.
  std::string header = dict.str();
  const size_t total = 10 + header.size() + 1;
  header.append((64 - total % 64) % 64, ' ');
  header.push_back('\n');
  if (header.size() > 0xffff) throw std::invalid_argument("writeNpy: a header of " + std::to_string(header.size()) + " bytes");
  std::string file("\x93NUMPY\x01\x00", 8);
  file.push_back(static_cast<char>(header.size() & 0xff));
  file.push_back(static_cast<char>(header.size() >> 8));
  file += header;
  file.append(static_cast<const char*>(data), bytes);
  writeFileBytes(path, file.data(), file.size());
}

}  // namespace mm

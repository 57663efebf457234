// ROS 2 bags (rosbag2, sqlite3 storage) as native logs (include/ftid/logio/input.hpp,
// docs/log-format.md "ROS 2 bags").
#include <sqlite3.h>
#include <sys/stat.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <memory>

#include "ftid/common/error.hpp"
#include "ftid/fileio/atomic_file.hpp"
#include "ftid/fileio/input_file.hpp"
#include "ftid/logio/cdr.hpp"
#include "ftid/logio/input.hpp"

namespace ftid::logio {

namespace {

constexpr const char* kJointStateType = "sensor_msgs/msg/JointState";
constexpr const char* kWrenchType = "geometry_msgs/msg/WrenchStamped";
constexpr std::size_t kMaxMessagesPerTopic = 20'000'000;
constexpr std::int64_t kMaxBagNs = 4'000'000'000'000'000'000;  ///< receive times [ns since 1970]
constexpr std::array<const char*, 6> kUrJoints = {"shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint",
                                                  "wrist_1_joint",      "wrist_2_joint",       "wrist_3_joint"};

std::string trimmed(const std::string& s) {
  const std::size_t a = s.find_first_not_of(" \t\r'\"");
  const std::size_t b = s.find_last_not_of(" \t\r'\"");
  return a == std::string::npos ? "" : s.substr(a, b - a + 1);
}

struct Metadata {
  std::string storage;
  std::vector<std::string> files;
  std::string compression, compression_mode;
};

/// The two things ftid needs from metadata.yaml (a line scan: the file is untrusted and only
/// these keys matter): storage_identifier and relative_file_paths.
Metadata readMetadata(const std::string& dir) {
  const std::string path = dir + "/metadata.yaml";
  std::string text;
  try {
    text = readInputFile(path, "rosbag2 metadata", std::size_t{1} << 20);
  } catch (const FileError& e) {
    throw DataError(dir + ": cannot read the log file: it is a directory, and not a rosbag2 bag (" + e.what() + ")");
  }
  Metadata m;
  bool in_files = false;
  std::size_t start = 0, line_no = 0;
  while (start < text.size()) {
    std::size_t end = text.find('\n', start);
    if (end == std::string::npos) end = text.size();
    const std::string line = text.substr(start, end - start);
    start = end + 1;
    ++line_no;
    const std::string t = trimmed(line);
    if (in_files) {
      if (t.rfind("- ", 0) == 0) {
        const std::string f = trimmed(t.substr(2));
        if (f.empty() || f.find('/') != std::string::npos || f.find("..") != std::string::npos) {
          throw DataError(path + ":" + std::to_string(line_no) + ": relative_file_paths: '" + f.substr(0, 100) +
                          "' is not a file name inside the bag directory");
        }
        if (m.files.size() >= 1000) throw DataError(path + ": more than 1000 storage files");
        m.files.push_back(f);
        continue;
      }
      in_files = false;
    }
    if (t.rfind("storage_identifier:", 0) == 0) m.storage = trimmed(t.substr(19));
    if (t.rfind("compression_format:", 0) == 0) m.compression = trimmed(t.substr(19));
    if (t.rfind("compression_mode:", 0) == 0) m.compression_mode = trimmed(t.substr(17));
    if (t.rfind("relative_file_paths:", 0) == 0) {
      in_files = true;
      const std::string rest = trimmed(t.substr(20));
      if (rest.size() > 2 && rest.front() == '[') {  // flow style: [a.db3, b.db3]
        std::string item;
        for (char c : rest.substr(1)) {
          if (c == ',' || c == ']') {
            if (!trimmed(item).empty()) m.files.push_back(trimmed(item));
            item.clear();
          } else {
            item += c;
          }
        }
        in_files = false;
      }
    }
  }
  if (m.storage.empty()) throw DataError(path + ": no storage_identifier (not a rosbag2 metadata file?)");
  if (m.storage == "mcap") {
    throw DataError(dir + ": MCAP storage: ftid reads rosbag2 with sqlite3 storage (Debian 12 has no MCAP "
                          "library); convert it: ros2 bag convert -i " + dir + " -o out.yaml with storage_id: sqlite3");
  }
  if (!m.compression.empty() || (!m.compression_mode.empty() && m.compression_mode != "NONE")) {
    throw DataError(path + ": a compressed bag (compression_format '" + m.compression.substr(0, 40) +
                    "', compression_mode '" + m.compression_mode.substr(0, 40) +
                    "'): ftid reads uncompressed bags; decompress it: ros2 bag convert -i " + dir +
                    " -o out.yaml (out.yaml without compression)");
  }
  if (m.storage != "sqlite3") throw DataError(path + ": storage_identifier '" + m.storage.substr(0, 40) + "' (ftid reads sqlite3)");
  if (m.files.empty()) throw DataError(path + ": relative_file_paths lists no storage file");
  for (const std::string& f : m.files) {
    if (f.find('/') != std::string::npos || f.find("..") != std::string::npos) {
      throw DataError(path + ": relative_file_paths: '" + f.substr(0, 100) + "' is not a file name inside the bag");
    }
  }
  return m;
}

struct DbCloser {
  void operator()(sqlite3* db) const { sqlite3_close(db); }
};
struct StmtCloser {
  void operator()(sqlite3_stmt* s) const { sqlite3_finalize(s); }
};
using Db = std::unique_ptr<sqlite3, DbCloser>;
using Stmt = std::unique_ptr<sqlite3_stmt, StmtCloser>;

/// Counts sqlite's progress-handler calls (one per kProgressOps VM instructions) against a budget.
struct StepBudget {
  std::uint64_t calls = 0;
  std::uint64_t max_calls = 0;
};
constexpr int kProgressOps = 1000;

int onProgress(void* p) {
  auto* b = static_cast<StepBudget*>(p);
  return ++b->calls > b->max_calls ? 1 : 0;
}

/// Opens a storage file read-only and hardened (the file is untrusted): defensive mode, no trusted
/// schema, values limited to 1 MiB, and a VM step budget proportional to the file size (a
/// legitimate query over `messages` costs a bounded number of steps per stored byte).
Db openDb(const std::string& path, StepBudget& budget) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0 || !S_ISREG(st.st_mode)) {
    throw DataError(path + ": cannot read the bag's storage file: not a regular file (listed in metadata.yaml)");
  }
  if (static_cast<std::uint64_t>(st.st_size) > kMaxLogBytes) throw DataError(path + ": storage file larger than 2 GiB");
  sqlite3* raw = nullptr;
  const int rc = sqlite3_open_v2(path.c_str(), &raw, SQLITE_OPEN_READONLY | SQLITE_OPEN_NOMUTEX, nullptr);
  Db db(raw);
  if (rc != SQLITE_OK) throw DataError(path + ": cannot open as sqlite3: " + (raw ? sqlite3_errmsg(raw) : "out of memory"));
  sqlite3_db_config(raw, SQLITE_DBCONFIG_DEFENSIVE, 1, nullptr);
  sqlite3_db_config(raw, SQLITE_DBCONFIG_TRUSTED_SCHEMA, 0, nullptr);
  sqlite3_db_config(raw, SQLITE_DBCONFIG_ENABLE_TRIGGER, 0, nullptr);
  sqlite3_db_config(raw, SQLITE_DBCONFIG_ENABLE_VIEW, 0, nullptr);
  sqlite3_limit(raw, SQLITE_LIMIT_LENGTH, static_cast<int>(kMaxCdrMessageBytes));
  budget.calls = 0;
  budget.max_calls = (static_cast<std::uint64_t>(st.st_size) * 200 + 100'000'000) / kProgressOps;
  sqlite3_progress_handler(raw, kProgressOps, onProgress, &budget);
  return db;
}

Stmt prepare(sqlite3* db, const std::string& path, const char* sql) {
  sqlite3_stmt* raw = nullptr;
  if (sqlite3_prepare_v2(db, sql, -1, &raw, nullptr) != SQLITE_OK) {
    throw DataError(path + ": not a rosbag2 sqlite3 file (" + sqlite3_errmsg(db) + ")");
  }
  return Stmt(raw);
}

/// Refuses a storage file whose `topics` or `messages` is not a plain table (a view or virtual
/// table could produce endless rows from a few bytes).
void requirePlainTables(sqlite3* db, const std::string& path) {
  for (const char* name : {"topics", "messages"}) {
    Stmt s = prepare(db, path, "SELECT type, sql FROM sqlite_schema WHERE name = ?");
    sqlite3_bind_text(s.get(), 1, name, -1, SQLITE_STATIC);
    const int rc = sqlite3_step(s.get());
    if (rc != SQLITE_ROW) {
      throw DataError(path + ": not a rosbag2 sqlite3 file (no table '" + name + "'" +
                      (rc == SQLITE_DONE ? std::string() : std::string(": ") + sqlite3_errmsg(db)) + ")");
    }
    const unsigned char* type = sqlite3_column_text(s.get(), 0);
    const unsigned char* sql = sqlite3_column_text(s.get(), 1);
    const std::string sql_head = sql == nullptr ? "" : std::string(reinterpret_cast<const char*>(sql)).substr(0, 20);
    std::string upper;
    for (char c : sql_head) upper += static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
    const bool table = type != nullptr && std::string(reinterpret_cast<const char*>(type)) == "table" &&
                       upper.rfind("CREATE TABLE", 0) == 0;
    if (!table) {
      throw DataError(path + ": '" + name + "' is a " + (type == nullptr ? "?" : reinterpret_cast<const char*>(type)) +
                      " (" + sql_head + "...), not a plain table: not a rosbag2 storage file ftid will read");
    }
  }
}

/// The error of a failed sqlite3_step, naming the step budget if that interrupted it.
std::string stepError(sqlite3* db, const StepBudget& budget) {
  if (budget.calls > budget.max_calls) {
    return "interrupted after " + std::to_string(budget.max_calls * kProgressOps) +
           " sqlite steps (far more than a bag of this size needs)";
  }
  return sqlite3_errmsg(db);
}

std::string text(sqlite3_stmt* s, int col) {
  const unsigned char* t = sqlite3_column_text(s, col);
  return t == nullptr ? "" : std::string(reinterpret_cast<const char*>(t)).substr(0, 256);
}

struct Topic {
  std::string name;
  std::string type;
};

/// One message of a topic: the bag's receive time [ns] and the serialized bytes.
struct Raw {
  std::int64_t bag_ns = 0;
  std::vector<std::uint8_t> data;
  std::string file;
};

/// Seconds since `origin_s` (whole seconds): small numbers keep the differences exact to 1 ns
/// (Unix time itself as a double resolves only about 0.2 us).
double stampSeconds(std::int64_t sec, std::uint32_t nsec, std::int64_t origin_s) {
  return static_cast<double>(sec - origin_s) + nsec * 1e-9;
}
double bagSeconds(std::int64_t bag_ns, std::int64_t origin_s) {
  return static_cast<double>(bag_ns - origin_s * 1'000'000'000) * 1e-9;
}

/// Picks the topic named `want` (or, if `want` is empty, the only one of `type`).
std::string chooseTopic(const std::vector<Topic>& topics, const std::string& want, const char* type,
                        const char* option, const std::string& dir) {
  std::string listing;
  std::vector<std::string> of_type;
  for (const Topic& t : topics) {
    listing += (listing.empty() ? "" : ", ") + t.name + " (" + t.type + ")";
    if (t.type == type) of_type.push_back(t.name);
  }
  if (!want.empty()) {
    for (const Topic& t : topics) {
      if (t.name != want) continue;
      if (t.type != type) {
        throw DataError(dir + ": topic '" + want + "' is " + t.type + ", not " + type + " (" + option + ")");
      }
      return want;
    }
    throw DataError(dir + ": no topic '" + want + "' (" + option + "); the bag has: " + listing);
  }
  if (of_type.size() != 1) {
    throw DataError(dir + ": " + std::to_string(of_type.size()) + " topics of type " + type + ": name one with " +
                    option + "; the bag has: " + listing);
  }
  return of_type.front();
}

/// The messages of the joint topic and (if wanted) the wrench topic over every storage file.
struct BagMessages {
  std::string joint_topic, wrench_topic;
  std::vector<Raw> joint, wrench;
};

/// The topics of one storage file (id, topic); adds new names to `all`.
std::vector<std::pair<std::int64_t, Topic>> readTopics(sqlite3* db, const std::string& path, std::vector<Topic>& all,
                                                      const StepBudget& budget) {
  std::vector<std::pair<std::int64_t, Topic>> ids;
  Stmt s = prepare(db, path, "SELECT id, name, type, serialization_format FROM topics");
  int rc = 0;
  while ((rc = sqlite3_step(s.get())) == SQLITE_ROW) {
    Topic t{text(s.get(), 1), text(s.get(), 2)};
    if (text(s.get(), 3) != "cdr" && (t.type == kJointStateType || t.type == kWrenchType)) {
      throw DataError(path + ": topic '" + t.name + "' is serialized as '" + text(s.get(), 3) + "', not cdr");
    }
    if (ids.size() >= 10000) throw DataError(path + ": more than 10000 topics");
    ids.emplace_back(sqlite3_column_int64(s.get(), 0), t);
    if (std::none_of(all.begin(), all.end(), [&](const Topic& x) { return x.name == t.name; })) all.push_back(t);
  }
  if (rc != SQLITE_DONE) throw DataError(path + ": reading the topics table: " + stepError(db, budget));
  return ids;
}

/// Reads the chosen topics' messages of one storage file into `out`; `bytes_read` counts the
/// message bytes over every file (capped at kMaxLogBytes).
void readFileMessages(sqlite3* db, const std::string& path, const std::string& file,
                      const std::vector<std::pair<std::int64_t, Topic>>& ids, bool want_wrench, const StepBudget& budget,
                      BagMessages& out, std::size_t& bytes_read) {
  std::int64_t joint_id = -1, wrench_id = -1;
  for (const auto& [id, t] : ids) {
    if (t.name == out.joint_topic) joint_id = id;
    if (want_wrench && t.name == out.wrench_topic) wrench_id = id;
  }
  if (joint_id < 0 && wrench_id < 0) return;
  Stmt s = prepare(db, path, "SELECT topic_id, timestamp, data FROM messages WHERE topic_id IN (?, ?) ORDER BY timestamp, id");
  sqlite3_bind_int64(s.get(), 1, joint_id);
  sqlite3_bind_int64(s.get(), 2, wrench_id);
  int rc = 0;
  while ((rc = sqlite3_step(s.get())) == SQLITE_ROW) {
    const std::int64_t id = sqlite3_column_int64(s.get(), 0);
    const bool joint = id == joint_id;
    if (!joint && id != wrench_id) throw DataError(path + ": the messages query returned topic id " + std::to_string(id));
    const std::string& topic = joint ? out.joint_topic : out.wrench_topic;
    std::vector<Raw>& into = joint ? out.joint : out.wrench;
    if (into.size() >= kMaxMessagesPerTopic) throw DataError(path + ": more than 20 million messages on '" + topic + "'");
    const int n = sqlite3_column_bytes(s.get(), 2);
    if (n < 0 || static_cast<std::size_t>(n) > kMaxCdrMessageBytes) {
      throw DataError(path + ": a message of " + std::to_string(n) + " bytes on '" + topic + "'");
    }
    bytes_read += static_cast<std::size_t>(n) + sizeof(Raw);
    if (bytes_read > kMaxLogBytes) {
      throw DataError(path + ": the bag's messages on '" + out.joint_topic + "'" +
                      (want_wrench ? " and '" + out.wrench_topic + "'" : std::string()) +
                      " exceed 2 GiB over all storage files (ftid reads at most 2 GiB of a bag)");
    }
    const auto* b = static_cast<const std::uint8_t*>(sqlite3_column_blob(s.get(), 2));
    Raw r;
    r.bag_ns = sqlite3_column_int64(s.get(), 1);
    if (r.bag_ns < 0 || r.bag_ns > kMaxBagNs) {
      throw DataError(path + ": a message on '" + topic + "' has the receive time " + std::to_string(r.bag_ns) +
                      " ns (not a time between 1970 and 2096)");
    }
    if (b != nullptr) r.data.assign(b, b + n);
    r.file = file;
    into.push_back(std::move(r));
  }
  if (rc != SQLITE_DONE) throw DataError(path + ": reading the messages table: " + stepError(db, budget));
}

BagMessages readBagMessages(const std::string& dir, const Metadata& meta, const InputOptions& options, bool want_wrench) {
  BagMessages out;
  std::vector<Topic> topics;
  // Topics first, over every storage file (a topic may first appear in a later file).
  for (const std::string& f : meta.files) {
    const std::string path = dir + "/" + f;
    StepBudget budget;
    Db db = openDb(path, budget);
    requirePlainTables(db.get(), path);
    readTopics(db.get(), path, topics, budget);
  }
  out.joint_topic = chooseTopic(topics, options.joint_topic, kJointStateType, "--joint-topic", dir);
  if (want_wrench) out.wrench_topic = chooseTopic(topics, options.wrench_topic, kWrenchType, "--wrench-topic", dir);
  std::size_t bytes_read = 0;
  for (const std::string& f : meta.files) {
    const std::string path = dir + "/" + f;
    StepBudget budget;
    Db db = openDb(path, budget);
    requirePlainTables(db.get(), path);
    std::vector<Topic> unused;
    const auto ids = readTopics(db.get(), path, unused, budget);
    readFileMessages(db.get(), path, f, ids, want_wrench, budget, out, bytes_read);
  }
  return out;
}

std::string where(const std::string& dir, const std::string& topic, std::size_t i, const Raw& r) {
  return dir + "/" + r.file + ": topic '" + topic + "', message " + std::to_string(i + 1) + ": ";
}

/// Index of each UR joint (base..wrist 3) among `names` (exact, or after a '_' or '/' prefix);
/// names.size() where absent.
std::array<std::size_t, 6> urJointIndex(const std::vector<std::string>& names) {
  std::array<std::size_t, 6> idx{};
  for (std::size_t j = 0; j < 6; ++j) {
    const std::string ur = kUrJoints[j];
    idx[j] = names.size();
    for (std::size_t n = 0; n < names.size(); ++n) {
      const std::string& name = names[n];
      const bool suffix = name.size() > ur.size() && name.compare(name.size() - ur.size(), ur.size(), ur) == 0 &&
                          (name[name.size() - ur.size() - 1] == '_' || name[name.size() - ur.size() - 1] == '/');
      if (name == ur || suffix) idx[j] = n;
    }
  }
  return idx;
}

LogData jointLogOf(const std::string& dir, const BagMessages& bag, const InputOptions& options, std::int64_t origin_s,
                   std::vector<std::string>& notes) {
  std::vector<JointStateMsg> js;
  js.reserve(bag.joint.size());
  for (std::size_t i = 0; i < bag.joint.size(); ++i) {
    try {
      js.push_back(decodeJointState(bag.joint[i].data.data(), bag.joint[i].data.size()));
    } catch (const DataError& e) {
      throw DataError(where(dir, bag.joint_topic, i, bag.joint[i]) + e.what());
    }
  }
  if (js.size() < 2) throw DataError(dir + ": topic '" + bag.joint_topic + "' has " + std::to_string(js.size()) + " messages");
  const bool stamps = std::all_of(js.begin(), js.end(), [](const JointStateMsg& m) { return m.stamp_sec != 0 || m.stamp_nanosec != 0; });
  LogData robot;
  robot.source = dir;
  robot.has_wrench = false;
  bool has_qd = true;
  for (std::size_t i = 0; i < js.size(); ++i) {
    const JointStateMsg& m = js[i];
    const std::string at = where(dir, bag.joint_topic, i, bag.joint[i]);
    if (m.position.size() != m.name.size() || (!m.velocity.empty() && m.velocity.size() != m.name.size())) {
      throw DataError(at + std::to_string(m.name.size()) + " names but " + std::to_string(m.position.size()) +
                      " positions and " + std::to_string(m.velocity.size()) + " velocities");
    }
    const auto idx = urJointIndex(m.name);
    LogSample s;
    s.t = stamps ? stampSeconds(m.stamp_sec, m.stamp_nanosec, origin_s) : bagSeconds(bag.joint[i].bag_ns, origin_s);
    for (std::size_t j = 0; j < 6; ++j) {
      const std::size_t k = idx[j];
      if (k == m.name.size()) {
        std::string names;
        for (const auto& n : m.name) names += (names.empty() ? "" : ", ") + n;
        throw DataError(at + "no joint named '" + kUrJoints[j] + "' (UR joint names, in any order or with a prefix, " +
                        "are expected; the message has: " + names + ")");
      }
      const double q = m.position[k];
      const double qd = m.velocity.empty() ? 0.0 : m.velocity[k];
      if (!(std::abs(q) <= options.read.max_abs_q_rad) || !(std::abs(qd) <= options.read.max_abs_qd_rad_s)) {
        throw DataError(at + "joint '" + m.name[k] + "': position or velocity not finite or outside the plausible range");
      }
      s.q[static_cast<Eigen::Index>(j)] = q;
      s.qd[static_cast<Eigen::Index>(j)] = qd;
    }
    has_qd = has_qd && !m.velocity.empty();
    if (!robot.samples.empty() && !(s.t > robot.samples.back().t)) {
      throw DataError(at + "time " + std::to_string(s.t) + " s is not after the previous message's (" +
                      std::to_string(robot.samples.back().t) + " s)");
    }
    robot.samples.push_back(s);
  }
  notes.push_back(std::to_string(js.size()) + " JointState messages on '" + bag.joint_topic + "' (" +
                  (stamps ? "header stamps" : "the bag's receive times: the header stamps are zero") + ")");
  differenceJointLog(robot, has_qd, options.derivative_half_window, "JointState message", notes);
  for (const LogSample& s : robot.samples) {
    for (Eigen::Index j = 0; j < 6; ++j) {
      if (std::abs(s.qd[j]) <= options.read.max_abs_qd_rad_s && std::abs(s.qdd[j]) <= options.read.max_abs_qdd_rad_s2) {
        continue;
      }
      throw DataError(dir + ": topic '" + bag.joint_topic + "', at t = " + std::to_string(s.t) + " s: joint " +
                      std::to_string(j + 1) + ": the velocity " + std::to_string(s.qd[j]) + " rad/s or acceleration " +
                      std::to_string(s.qdd[j]) + " rad/s^2 from smoothed differences is outside the plausible range "
                      "(the joint states jump there)");
    }
  }
  return robot;
}

LogData wrenchLogOf(const std::string& dir, const BagMessages& bag, const InputOptions& options, std::int64_t origin_s,
                    std::vector<std::string>& notes) {
  std::vector<WrenchStampedMsg> ws;
  ws.reserve(bag.wrench.size());
  for (std::size_t i = 0; i < bag.wrench.size(); ++i) {
    try {
      ws.push_back(decodeWrenchStamped(bag.wrench[i].data.data(), bag.wrench[i].data.size()));
    } catch (const DataError& e) {
      throw DataError(where(dir, bag.wrench_topic, i, bag.wrench[i]) + e.what());
    }
  }
  if (ws.size() < 2) throw DataError(dir + ": topic '" + bag.wrench_topic + "' has " + std::to_string(ws.size()) + " messages");
  const bool stamps = std::all_of(ws.begin(), ws.end(), [](const WrenchStampedMsg& m) { return m.stamp_sec != 0 || m.stamp_nanosec != 0; });
  LogData wrench;
  wrench.source = dir + " topic " + bag.wrench_topic;
  wrench.has_joints = false;
  for (std::size_t i = 0; i < ws.size(); ++i) {
    const std::string at = where(dir, bag.wrench_topic, i, bag.wrench[i]);
    LogSample s;
    s.t = stamps ? stampSeconds(ws[i].stamp_sec, ws[i].stamp_nanosec, origin_s) : bagSeconds(bag.wrench[i].bag_ns, origin_s);
    for (std::size_t a = 0; a < 6; ++a) {
      if (!(std::abs(ws[i].wrench[static_cast<Eigen::Index>(a)]) <= options.read.max_abs_wrench_S[a])) {
        throw DataError(at + "wrench component " + std::to_string(a) +
                        " not finite or outside the plausible range (100x the sensor's rated range)");
      }
    }
    s.wrench_S = ws[i].wrench;
    if (!wrench.samples.empty() && !(s.t > wrench.samples.back().t)) {
      throw DataError(at + "time " + std::to_string(s.t) + " s is not after the previous message's");
    }
    wrench.samples.push_back(s);
  }
  notes.push_back(std::to_string(ws.size()) + " WrenchStamped messages on '" + bag.wrench_topic + "' in frame '" +
                  ws.front().frame_id + "' (taken as the sensor frame S; " +
                  (stamps ? "header stamps)" : "the bag's receive times)"));
  return wrench;
}

}  // namespace

bool isDirectory(const std::string& path) {
  struct stat st {};
  return ::stat(path.c_str(), &st) == 0 && S_ISDIR(st.st_mode);
}

InputLog readRosbag2(const std::string& dir, const InputOptions& options) {
  const Metadata meta = readMetadata(dir);
  const bool want_wrench = options.wrench_log.empty();
  const BagMessages bag = readBagMessages(dir, meta, options, want_wrench);
  if (bag.joint_topic.empty()) throw DataError(dir + ": no storage file");
  InputLog in;
  in.format = "rosbag2 (sqlite3)";
  // t counts from the whole second of the bag's first joint state (its receive time).
  if (bag.joint.empty()) throw DataError(dir + ": topic '" + bag.joint_topic + "' has no messages");
  const std::int64_t origin_s = bag.joint.front().bag_ns / 1'000'000'000;
  in.notes.push_back("t counts from " + std::to_string(origin_s) + " s (Unix time: the whole second of the first "
                     "joint state's receive time)");
  LogData robot = jointLogOf(dir, bag, options, origin_s, in.notes);
  if (!want_wrench) {
    in.log = std::move(robot);  // readInput aligns the --wrench-log file
    return in;
  }
  const LogData wrench = wrenchLogOf(dir, bag, options, origin_s, in.notes);
  in.log = alignWrench(robot, wrench, options.wrench_time_offset_s, in.notes);
  return in;
}

void differenceJointLog(LogData& log, bool has_qd, int half_window, const std::string& what,
                        std::vector<std::string>& notes) {
  const std::size_t n0 = log.samples.size();
  std::vector<bool> same(n0, false);
  std::vector<int> moving(n0, -1);
  for (std::size_t i = 0; i < n0; ++i) {
    if (i > 0) same[i] = log.samples[i].q == log.samples[i - 1].q && log.samples[i].qd == log.samples[i - 1].qd;
    if (has_qd) moving[i] = log.samples[i].qd.isZero(0.0) ? 0 : 1;
  }
  const std::vector<bool> drop = stairSteps(same, moving);
  std::size_t kept = 0;
  for (std::size_t i = 0; i < n0; ++i) {
    if (drop[i]) continue;
    log.samples[kept] = log.samples[i];
    for (auto& c : log.extra_columns) c[kept] = c[i];
    ++kept;
  }
  log.samples.resize(kept);
  for (auto& c : log.extra_columns) c.resize(kept);
  if (kept < n0) {
    notes.push_back("dropped " + std::to_string(n0 - kept) + " of " + std::to_string(n0) + " " + what +
                    "s whose joint state repeats the previous one exactly while the arm moves (stair steps: "
                    "differences across them would be wrong)");
  }
  const int h = std::max(1, half_window);
  std::vector<double> t(kept);
  std::vector<JointVector> y(kept);
  for (std::size_t i = 0; i < kept; ++i) t[i] = log.samples[i].t;
  if (!has_qd) {
    for (std::size_t i = 0; i < kept; ++i) y[i] = log.samples[i].q;
    const auto qd = smoothedDerivative(t, y, h);
    for (std::size_t i = 0; i < kept; ++i) log.samples[i].qd = qd[i];
    notes.emplace_back("joint velocities from smoothed differences of the positions (no velocities recorded)");
  }
  for (std::size_t i = 0; i < kept; ++i) y[i] = log.samples[i].qd;
  const auto qdd = smoothedDerivative(t, y, h);
  for (std::size_t i = 0; i < kept; ++i) log.samples[i].qdd = qdd[i];
  notes.push_back("joint accelerations from smoothed differences of the velocities (centred least-squares slope "
                  "over +-" + std::to_string(h) + " samples; no lag)");
}

}  // namespace ftid::logio

// Case folder integrity: SHA-256 against published vectors, the append-only log's hash chain,
// the manifest, and verify_case naming each changed, missing or added file.
#include <locard/forensics/case_folder.hpp>
#include <locard/forensics/evidence_markers.hpp>
#include <locard/forensics/integrity.hpp>

#include <locard/core/atomic_file.hpp>
#include <locard/core/error.hpp>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "test_support.hpp"

#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <csignal>
#include <fstream>
#include <set>
#include <thread>

namespace locard::forensics {
namespace {

namespace fs = std::filesystem;

void write(const fs::path& p, const std::string& text) {
  fs::create_directories(p.parent_path());
  std::ofstream(p, std::ios::binary) << text;
}

void flip_byte(const fs::path& p, std::size_t offset) {
  std::fstream f(p, std::ios::binary | std::ios::in | std::ios::out);
  f.seekg(static_cast<std::streamoff>(offset));
  char c = 0;
  f.get(c);
  f.seekp(static_cast<std::streamoff>(offset));
  f.put(static_cast<char>(c ^ 0x01));
}

// A case with case.json, one input outside it and one output, logged.
CaseFolder make_case(const fs::path& dir, const fs::path& input_dir) {
  write(input_dir / "depth" / "000000.png", "depth bytes");
  CaseFolder c = CaseFolder::create(dir / "case", false);
  const std::string input_hash = sha256_file(input_dir / "depth" / "000000.png");
  nlohmann::json cj = {{"inputs", {{"root", input_dir.string()},
                                   {"files", {{{"path", "depth/000000.png"},
                                               {"bytes", 11},
                                               {"sha256", input_hash}}}}}}};
  write(c.path("case.json"), cj.dump());
  write(c.path("mesh/mesh.ply"), "ply\nformat binary_little_endian 1.0\nend_header\n0123456789");
  LogStep s;
  s.step = "mesh";
  s.parameters_json = R"({"voxel_m": 0.01})";
  s.inputs = {input_dir / "depth" / "000000.png"};
  s.outputs = {"case.json", "mesh/mesh.ply"};
  c.append_log_step(s);
  return c;
}

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

std::set<std::string> findings(const VerifyReport& r) {
  std::set<std::string> out;
  for (const auto& p : r.problems) out.insert(std::string(to_string(p.kind)) + " " + p.path);
  return out;
}

TEST(Sha256, PublishedVectors) {
  // FIPS 180-2 examples.
  EXPECT_EQ(sha256_hex(std::string_view("abc")),
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
  EXPECT_EQ(sha256_hex(std::string_view("")),
            "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855");
  const fs::path dir = test::scratch_dir();
  write(dir / "f", "abc");
  EXPECT_EQ(sha256_file(dir / "f"), sha256_hex(std::string_view("abc")));
  EXPECT_THROW(sha256_file(dir / "missing"), InputError);
}

TEST(CaseFolder, RefusesToWriteOverWithoutForce) {
  const fs::path dir = test::scratch_dir();
  write(dir / "busy" / "notes.txt", "someone's notes");
  EXPECT_THROW(CaseFolder::create(dir / "busy", false), InputError);
  // Not a case: even --force leaves it alone.
  EXPECT_THROW(CaseFolder::create(dir / "busy", true), InputError);
  EXPECT_TRUE(fs::exists(dir / "busy" / "notes.txt"));
  write(dir / "file", "x");
  EXPECT_THROW(CaseFolder::create(dir / "file", true), InputError);
  make_case(dir, dir / "input");
  EXPECT_THROW(CaseFolder::create(dir / "case", false), InputError);
  EXPECT_NO_THROW(CaseFolder::create(dir / "case", true));
  EXPECT_TRUE(fs::is_empty(dir / "case"));
  EXPECT_THROW(CaseFolder::open(dir / "busy", CaseAccess::Read), InputError);
}

TEST(CaseFolder, LogIsAHashChainAndManifestListsEveryFile) {
  const fs::path dir = test::scratch_dir();
  CaseFolder c = make_case(dir, dir / "input");
  write(c.path("evidence/markers.json"), "{}");
  LogStep s;
  s.step = "marker add";
  s.outputs = {"evidence/markers.json"};
  EXPECT_EQ(c.append_log_step(s), 1u);
  std::ifstream log(dir / "case" / "log.jsonl");
  std::string l0, l1;
  std::getline(log, l0);
  std::getline(log, l1);
  const auto j0 = nlohmann::json::parse(l0), j1 = nlohmann::json::parse(l1);
  EXPECT_EQ(j0["prev_sha256"], "");
  EXPECT_EQ(j1["prev_sha256"], sha256_hex(l0));
  EXPECT_EQ(j0["parameters"]["voxel_m"], 0.01);
  EXPECT_EQ(j0["inputs"][0]["sha256"], sha256_hex(std::string_view("depth bytes")));
  const auto manifest = nlohmann::json::parse(std::ifstream(dir / "case" / "manifest.json"));
  EXPECT_EQ(manifest["files"].size(), 4u);  // case.json, log.jsonl, mesh.ply, markers.json
  EXPECT_EQ(manifest["log_head_sha256"], sha256_hex(l1));
  const VerifyReport r = verify_case(dir / "case");
  EXPECT_TRUE(r.ok());
  EXPECT_EQ(r.files_checked, 4u);
  EXPECT_EQ(r.inputs_checked, 1u);
  EXPECT_EQ(r.log_lines, 2u);
  // Bad steps are refused.
  LogStep bad;
  bad.step = "x";
  bad.parameters_json = "[1]";
  EXPECT_THROW(c.append_log_step(bad), InputError);
  bad.parameters_json = "{}";
  bad.outputs = {"not/there.txt"};
  EXPECT_THROW(c.append_log_step(bad), InputError);
}

TEST(VerifyCase, NamesChangedMissingAndAddedFiles) {
  const fs::path dir = test::scratch_dir();
  make_case(dir, dir / "input");
  flip_byte(dir / "case" / "mesh" / "mesh.ply", 50);
  write(dir / "case" / "extra.txt", "planted");
  VerifyReport r = verify_case(dir / "case");
  ASSERT_EQ(r.problems.size(), 2u);
  std::set<std::string> seen;
  for (const auto& p : r.problems) seen.insert(std::string(to_string(p.kind)) + " " + p.path);
  EXPECT_TRUE(seen.count("changed mesh/mesh.ply"));
  EXPECT_TRUE(seen.count("added extra.txt"));
  fs::remove(dir / "case" / "mesh" / "mesh.ply");
  r = verify_case(dir / "case");
  EXPECT_EQ(r.problems[0].kind, VerifyProblem::Kind::Missing);
  EXPECT_EQ(r.problems[0].path, "mesh/mesh.ply");
}

TEST(VerifyCase, InputChangedAndLogTampering) {
  const fs::path dir = test::scratch_dir();
  make_case(dir, dir / "input");
  flip_byte(dir / "input" / "depth" / "000000.png", 0);
  VerifyReport r = verify_case(dir / "case");
  ASSERT_EQ(r.problems.size(), 1u);
  EXPECT_EQ(r.problems[0].kind, VerifyProblem::Kind::InputChanged);
  EXPECT_NE(r.problems[0].path.find("000000.png"), std::string::npos);
  EXPECT_TRUE(verify_case(dir / "case", false).ok());  // inputs skipped

  // Editing a log line breaks both the manifest hash and the chain head.
  const fs::path other = test::scratch_dir();
  make_case(other, other / "input");
  flip_byte(other / "case" / "log.jsonl", 10);
  r = verify_case(other / "case");
  bool chain = false, changed = false;
  for (const auto& p : r.problems) {
    chain |= p.kind == VerifyProblem::Kind::LogChain;
    changed |= p.kind == VerifyProblem::Kind::Changed && p.path == "log.jsonl";
  }
  EXPECT_TRUE(chain);
  EXPECT_TRUE(changed);
  // A tampered manifest that is not JSON is an InputError, not a pass.
  write(other / "case" / "manifest.json", "{ not json");
  EXPECT_THROW(verify_case(other / "case"), InputError);
}

// The case lock (case_lock.hpp): a thread that opens a case another thread holds waits for
// it; the holder may open it again itself (re-entrant) without deadlocking.
TEST(CaseFolder, HoldsTheCaseOneCommandAtATime) {
  const fs::path root = test::scratch_dir() / "locked";
  {
    CaseFolder c = CaseFolder::create(root, false);
    LogStep s;
    s.step = "create";
    c.append_log_step(s);
  }
  std::ofstream(root / "case.json") << "{}";
  std::atomic<bool> released{false};
  std::atomic<bool> second_saw_release{false};
  std::thread holder([&] {
    const CaseFolder first = CaseFolder::open(root, CaseAccess::Read);
    const CaseFolder again = CaseFolder::open(root, CaseAccess::Read);  // the same thread: no deadlock
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
    released = true;
  });
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
  std::thread waiter([&] {
    const CaseFolder second = CaseFolder::open(root, CaseAccess::Read);
    second_saw_release = released.load();
  });
  holder.join();
  waiter.join();
  EXPECT_TRUE(second_saw_release) << "the second opener ran while the first held the case";
}

// Issue 14 (laundering): the manifest was re-hashed from the disk after every step, so a file
// deleted or planted before a routine step vanished from the record. It is now written from
// the log, and a command that changes the case verifies it first and refuses.
TEST(CaseFolder, ManifestComesFromTheLogAndAChangeRefusesACaseThatDoesNotVerify) {
  const fs::path dir = test::scratch_dir();
  { make_case(dir, dir / "input"); }
  const fs::path root = dir / "case";
  fs::remove(root / "mesh" / "mesh.ply");
  write(root / "planted.txt", "not from any step");
  const std::string manifest = slurp(root / "manifest.json");
  try {
    CaseFolder::open(root, CaseAccess::Change);
    ADD_FAILURE() << "a case missing its mesh was opened for a change";
  } catch (const CaseNotIntact& e) {
    std::set<std::string> seen;
    for (const auto& p : e.problems()) seen.insert(std::string(to_string(p.kind)) + " " + p.path);
    EXPECT_TRUE(seen.count("missing mesh/mesh.ply")) << e.what();
    EXPECT_TRUE(seen.count("added planted.txt")) << e.what();
    EXPECT_NE(std::string(e.what()).find("mesh/mesh.ply"), std::string::npos) << e.what();
  }
  EXPECT_EQ(slurp(root / "manifest.json"), manifest);
  // Read access still works (verify, listing), and appending through it is refused.
  CaseFolder read = CaseFolder::open(root, CaseAccess::Read);
  LogStep s;
  s.step = "x";
  EXPECT_THROW(read.append_log_step(s), Error);
  // The manifest lists what the log recorded, not what is on disk.
  const auto m = nlohmann::json::parse(manifest);
  EXPECT_TRUE(m["files"].contains("mesh/mesh.ply"));
  EXPECT_FALSE(m["files"].contains("planted.txt"));
  EXPECT_EQ(m["source"], "log");
  // A step that removes an output says so, and the record drops it.
  const fs::path other = dir / "second";
  CaseFolder c = make_case(other, other / "input");
  fs::remove(other / "case" / "mesh" / "mesh.ply");
  LogStep removal;
  removal.step = "remove mesh";
  removal.removed = {"mesh/mesh.ply"};
  c.append_log_step(removal);
  EXPECT_TRUE(verify_case(other / "case").ok());
}

// Issue 14 (disk full): `marker add` appended its log line, then failed writing the manifest,
// and the case read as tampered. A change is now all or nothing: here a file-size limit makes
// the log's rewrite fail (EFBIG, as a full disk fails a write), and the markers file the step
// had written, the log and the manifest are all as they were; nothing partial is left.
TEST(CaseChange, AWriteThatFailsLeavesTheCaseAsItWas) {
  const fs::path dir = test::scratch_dir();
  CaseFolder c = make_case(dir, dir / "input");
  const fs::path root = dir / "case";
  write(root / "evidence" / "markers.json", "{}");
  {
    LogStep first;
    first.step = "marker add";
    first.outputs = {"evidence/markers.json"};
    c.append_log_step(first);
  }
  const std::string log = slurp(root / "log.jsonl"), manifest = slurp(root / "manifest.json");
  const std::string markers = slurp(root / "evidence" / "markers.json");
  ASSERT_GT(log.size(), 200u);
  {
    LogStep step;
    step.step = "marker add";
    step.outputs = {"evidence/markers.json", "evidence/markers.csv"};
    CaseChange change(c, step.outputs);
    MarkerSet set;
    EvidenceMarker m;
    m.label = "casing";
    set.add(m);
    write_markers(root / "evidence" / "markers.json", set);  // small: fits under the limit
    ASSERT_NE(slurp(root / "evidence" / "markers.json"), markers);
    // The log grows past the limit: its rewrite fails like a write to a full disk.
    rlimit old{};
    ASSERT_EQ(getrlimit(RLIMIT_FSIZE, &old), 0);
    const auto old_handler = std::signal(SIGXFSZ, SIG_IGN);
    rlimit tight = old;
    tight.rlim_cur = log.size() + 100;
    ASSERT_EQ(setrlimit(RLIMIT_FSIZE, &tight), 0);
    EXPECT_THROW(change.commit(step), Error);
    setrlimit(RLIMIT_FSIZE, &old);
    std::signal(SIGXFSZ, old_handler);
  }
  EXPECT_EQ(slurp(root / "log.jsonl"), log);
  EXPECT_EQ(slurp(root / "manifest.json"), manifest);
  EXPECT_EQ(slurp(root / "evidence" / "markers.json"), markers);
  EXPECT_FALSE(fs::exists(root / "evidence" / "markers.csv"));
  EXPECT_FALSE(fs::exists(root / ".locard-undo"));
  const VerifyReport r = verify_case(root);
  EXPECT_TRUE(r.ok()) << (r.problems.empty() ? "" : r.problems[0].path + ": " + r.problems[0].detail);
}

// Issue 14 (half cases): a command of several steps logs "begin" first and "complete" last;
// killed or failed in between, verify says INCOMPLETE with the last step - never OK.
TEST(VerifyCase, ACommandThatDidNotCompleteIsIncomplete) {
  const fs::path dir = test::scratch_dir();
  CaseFolder c = CaseFolder::create(dir / "case", false);
  LogStep begin;
  begin.step = "reconstruct";
  begin.phase = StepPhase::Begin;
  c.append_log_step(begin);
  write(c.path("case.json"), "{}");
  LogStep ingest;
  ingest.step = "ingest";
  ingest.outputs = {"case.json"};
  c.append_log_step(ingest);
  VerifyReport r = verify_case(dir / "case");
  ASSERT_EQ(r.problems.size(), 1u);
  EXPECT_TRUE(r.only_incomplete());
  EXPECT_NE(r.problems[0].detail.find("INCOMPLETE"), std::string::npos) << r.problems[0].detail;
  EXPECT_NE(r.problems[0].detail.find("line 2 'ingest'"), std::string::npos) << r.problems[0].detail;
  LogStep failed = begin;
  failed.phase = StepPhase::Failed;
  failed.parameters_json = R"({"error": "depth/000003.png: corrupt PNG"})";
  c.append_log_step(failed);
  r = verify_case(dir / "case");
  ASSERT_TRUE(r.only_incomplete());
  EXPECT_NE(r.problems[0].detail.find("corrupt PNG"), std::string::npos) << r.problems[0].detail;
  LogStep complete = begin;
  complete.phase = StepPhase::Complete;
  c.append_log_step(complete);
  EXPECT_TRUE(verify_case(dir / "case").ok());
}

// Issue 14 (inputs): an input recorded by absolute path (a frame named outside the input
// folder) is re-hashed where it lives; a file added to the input folder is reported.
TEST(VerifyCase, InputsWhereverTheyLiveAndFilesAddedToTheInputFolder) {
  const fs::path dir = test::scratch_dir();
  CaseFolder c = make_case(dir, dir / "input");
  write(dir / "elsewhere" / "frame.png", "outside");
  nlohmann::json cj = nlohmann::json::parse(slurp(dir / "case" / "case.json"));
  cj["inputs"]["files"].push_back({{"path", (dir / "elsewhere" / "frame.png").string()},
                                   {"bytes", 7},
                                   {"sha256", sha256_file(dir / "elsewhere" / "frame.png")}});
  write(dir / "case" / "case.json", cj.dump());
  LogStep s;
  s.step = "ingest again";
  s.outputs = {"case.json"};
  c.append_log_step(s);
  EXPECT_TRUE(verify_case(dir / "case").ok());
  flip_byte(dir / "elsewhere" / "frame.png", 0);
  write(dir / "input" / "depth" / "000001.png", "added later");
  const VerifyReport r = verify_case(dir / "case");
  const auto seen = findings(r);
  EXPECT_TRUE(seen.count("input changed " + (dir / "elsewhere" / "frame.png").string()));
  EXPECT_TRUE(seen.count("input added " + (dir / "input" / "depth" / "000001.png").string()));
  EXPECT_EQ(r.problems.size(), 2u);
}

// Issue 14 (fuzzing, case_fuzz's find): a log output whose "bytes" was a string ended verify
// with nlohmann's raw type_error (std::terminate under the fuzzer). Every field of a record
// edited to the wrong type - in the log, the manifest and case.json's inputs, chain re-made so
// only the types are wrong - is now a finding naming the line and the field.
TEST(CaseFolder, FieldsOfTheWrongTypeAreFindingsNotExceptions) {
  const fs::path dir = test::scratch_dir();
  { make_case(dir, dir / "input"); }
  const CaseFolder c = CaseFolder::open(dir / "case", CaseAccess::Read);
  std::string line = slurp(c.path("log.jsonl"));
  line = line.substr(0, line.find('\n'));
  nlohmann::json j = nlohmann::json::parse(line);
  j["outputs"][1]["bytes"] = "x";
  j["step"] = 7;
  write(c.path("log.jsonl"), j.dump() + "\n");
  nlohmann::json manifest = nlohmann::json::parse(slurp(c.path("manifest.json")));
  manifest["log_head_sha256"] = nlohmann::json::array();
  manifest["files"]["mesh/mesh.ply"]["sha256"] = 12;
  write(c.path("manifest.json"), manifest.dump());
  nlohmann::json cj = nlohmann::json::parse(slurp(c.path("case.json")));
  cj["inputs"]["files"][0]["sha256"] = false;
  write(c.path("case.json"), cj.dump());

  VerifyReport r;
  ASSERT_NO_THROW(r = verify_case(c.root(), true));
  std::string all;
  for (const auto& p : r.problems) all += std::string(to_string(p.kind)) + " " + p.path + ": " + p.detail + "\n";
  EXPECT_NE(all.find("line 1: \"bytes\" is string, not a whole number"), std::string::npos) << all;
  EXPECT_NE(all.find("line 1: \"step\" is number, not a string"), std::string::npos) << all;
  EXPECT_NE(all.find("manifest.json: \"log_head_sha256\" is array, not a string"), std::string::npos) << all;
  EXPECT_NE(all.find("manifest.json: \"sha256\" is number, not a string"), std::string::npos) << all;
  EXPECT_NE(all.find("case.json inputs: \"sha256\" is boolean, not a string"), std::string::npos) << all;
  // A command that would change the case refuses it, naming the finding; nothing is written.
  const std::string log_before = slurp(c.path("log.jsonl"));
  EXPECT_THROW((void)CaseFolder::open(c.root(), CaseAccess::Change), CaseNotIntact);
  EXPECT_EQ(slurp(c.path("log.jsonl")), log_before);
}

// Issue 14 (writers that cannot lose data): a command killed (SIGKILL) in the middle of its
// change left its half-written file and the kept copies in .locard-undo/, and the case then
// read as tampered for good. Verify now says a change was interrupted; the next command that
// changes the case puts the files back from the journal, logs that it did, and goes on.
TEST(CaseChange, AChangeKilledHalfWayIsUndoneByTheNextCommand) {
  const fs::path dir = test::scratch_dir();
  { make_case(dir, dir / "input"); }
  const fs::path root = dir / "case";
  const std::string mesh_before = slurp(root / "mesh" / "mesh.ply");
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {  // the command that is killed: no destructor, no commit runs
    CaseFolder folder = CaseFolder::open(root, CaseAccess::Change);
    CaseChange change(folder, {"mesh/mesh.ply", "evidence/new.json"});
    {  // as the writers do: a whole new file renamed over the old one
      AtomicFile mesh(root / "mesh" / "mesh.ply");
      mesh.stream() << "a new mesh";
      mesh.commit();
    }
    write(root / "evidence" / "new.json", "{");  // and one half-written
    ::raise(SIGKILL);
  }
  int status = 0;
  ASSERT_EQ(::waitpid(child, &status, 0), child);
  ASSERT_TRUE(WIFSIGNALED(status));
  ASSERT_TRUE(fs::exists(root / ".locard-undo"));

  const VerifyReport before = verify_case(root, false);
  EXPECT_TRUE(findings(before).count("changed mesh/mesh.ply")) << before.problems.size();
  bool interrupted = false;
  for (const auto& p : before.problems)
    interrupted |= p.kind == VerifyProblem::Kind::Incomplete && p.path.rfind(".locard-undo/", 0) == 0;
  EXPECT_TRUE(interrupted);

  {
    CaseFolder folder = CaseFolder::open(root, CaseAccess::Change);  // recovers, then verifies
    EXPECT_EQ(slurp(root / "mesh" / "mesh.ply"), mesh_before);
    EXPECT_FALSE(fs::exists(root / "evidence" / "new.json"));
    EXPECT_FALSE(fs::exists(root / ".locard-undo"));
  }
  const VerifyReport after = verify_case(root, true);
  EXPECT_TRUE(after.ok()) << (after.ok() ? "" : after.problems[0].path + ": " + after.problems[0].detail);
  const std::string log = slurp(root / "log.jsonl");
  EXPECT_NE(log.find("\"step\":\"recover interrupted change\""), std::string::npos) << log;
  EXPECT_NE(log.find("mesh/mesh.ply"), std::string::npos);
}

// Issue 14: anchors/ is outside the log, and a file planted there went unreported. Only a
// signature or time stamp named for a line of this log may be there.
TEST(VerifyCase, AFilePlantedAmongTheAnchorsIsReported) {
  const fs::path dir = test::scratch_dir();
  { make_case(dir, dir / "input"); }
  const fs::path root = dir / "case";
  const std::string head16 = log_head_sha256(root).substr(0, 16);
  write(root / "anchors" / ("timestamp-" + head16 + ".tsr"), "token");
  write(root / "anchors" / ("signature-" + head16 + "-0123abcd.json"), "{}");
  EXPECT_TRUE(verify_case(root, false).ok());
  write(root / "anchors" / "notes.txt", "planted");
  write(root / "anchors" / "timestamp-0000000000000000.tsr", "of another case");
  EXPECT_EQ(findings(verify_case(root, false)),
            (std::set<std::string>{"added anchors/notes.txt", "added anchors/timestamp-0000000000000000.tsr"}));
}

}  // namespace
}  // namespace locard::forensics

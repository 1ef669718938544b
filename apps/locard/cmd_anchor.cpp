// Anchors over a case's log head (include/locard/forensics/anchors.hpp):
//   locard sign CASE --key KEY.pem                   Ed25519 signature into CASE/anchors/
//   locard timestamp request CASE -o REQ.tsq         an RFC 3161 request to send to a TSA
//   locard timestamp store CASE RESP.tsr             the TSA's answer, kept in CASE/anchors/
// `locard verify CASE --public-key PUB.pem --tsa-cert CA.pem` checks them.
#include "commands.hpp"

#include <locard/forensics/anchors.hpp>

#include <fmt/format.h>

#include <memory>

namespace locard::cli {
namespace {

namespace fx = locard::forensics;

struct AnchorCli {
  std::string case_dir;
  std::string key;
  std::string request_out;
  std::string response;
};

int run_sign(const AnchorCli& o) {
  const fx::SignatureResult r = fx::sign_case(o.case_dir, o.key);
  fmt::print("sign: {} (Ed25519, key sha256 {})\n", r.file.string(), r.public_key_sha256);
  fmt::print("case log head: sha256 {}\n", r.log_head_sha256);
  return 0;
}

int run_request(const AnchorCli& o) {
  const std::string head = fx::write_timestamp_request(o.case_dir, o.request_out);
  fmt::print("timestamp: wrote {}; send it to a time-stamp authority (e.g. `curl -H "
             "'Content-Type: application/timestamp-query' --data-binary @{} URL -o RESP.tsr`), "
             "then `locard timestamp store {} RESP.tsr`\n",
             o.request_out, o.request_out, o.case_dir);
  fmt::print("case log head: sha256 {}\n", head);
  return 0;
}

int run_store(const AnchorCli& o) {
  const auto stored = fx::store_timestamp_response(o.case_dir, o.response);
  fmt::print("timestamp: stored {} (checked by `locard verify --tsa-cert CA.pem`)\n",
             stored.string());
  return 0;
}

}  // namespace

void register_sign(CLI::App& app, GlobalOptions&) {
  auto o = std::make_shared<AnchorCli>();
  CLI::App* cmd = app.add_subcommand(
      "sign", "Sign a case's manifest and log head with an Ed25519 key (anchors/signature-*.json);"
              " the case must verify. Check with `verify --public-key`");
  cmd->add_option("case", o->case_dir, "Case folder")->required();
  cmd->add_option("--key", o->key, "Ed25519 private key, PEM (openssl genpkey -algorithm ed25519)")
      ->required();
  set_runner(cmd, [o] { return run_sign(*o); });
}

void register_timestamp(CLI::App& app, GlobalOptions&) {
  auto o = std::make_shared<AnchorCli>();
  CLI::App* cmd = app.add_subcommand(
      "timestamp", "RFC 3161 time stamps over a case's log head: request, then store the answer");
  cmd->require_subcommand(1);
  CLI::App* request = cmd->add_subcommand(
      "request", "Write a time-stamp request (DER, SHA-256 of the log's last line) for a TSA");
  request->add_option("case", o->case_dir, "Case folder")->required();
  request->add_option("-o,--output", o->request_out, "Request file to write (.tsq)")->required();
  CLI::App* store = cmd->add_subcommand(
      "store", "Keep a TSA's response in the case (anchors/timestamp-*.tsr) after checking it "
               "stamps a line of the log");
  store->add_option("case", o->case_dir, "Case folder")->required();
  store->add_option("response", o->response, "The TSA's response (.tsr, DER)")->required();
  set_runner(cmd, [o, request, store] {
    if (request->parsed()) return run_request(*o);
    if (store->parsed()) return run_store(*o);
    return 2;
  });
}

}  // namespace locard::cli

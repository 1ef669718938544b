#pragma once
// Anchors: proofs kept beside a case's record that pin its log head to a key or to a time.
// The log head (the SHA-256 of log.jsonl's last line) pins every step up to it, since each
// line holds the hash of the one before; a forger who changes a file, re-hashes the log and
// re-chains it (which `verify` alone cannot tell from the truth) changes the head, and no
// anchor made before holds for the new one.
//
// Files: CASE/anchors/ (not in the manifest or the log - they sign those):
//   signature-<head 16 hex>.json  {"format": "locard-case-signature/1", "algorithm": "Ed25519",
//       "message": "<the signed text>", "signature_base64", "public_key_sha256", "signed_at"}
//     The message: "locard-case-signature/1\nlog_head_sha256 <hex>\nlog_lines <n>\n
//     manifest_sha256 <hex>\n" - the manifest of the moment and the head.
//   timestamp-<head 16 hex>.tsr   an RFC 3161 time-stamp response (DER) whose message imprint
//     is SHA-256 over the log's last line at the time, i.e. the head itself, so that
//     `openssl ts -verify -data LAST_LINE` checks it too.
// Keys are PEM, as `openssl genpkey -algorithm ed25519` (and `openssl pkey -pubout`) write
// them; OpenSSL's EVP and TS interfaces do the cryptography.

#include <locard/forensics/case_folder.hpp>

#include <filesystem>
#include <string>
#include <vector>

namespace locard::forensics {

struct SignatureResult {
  std::filesystem::path file;
  std::string log_head_sha256;
  std::string public_key_sha256;  // SHA-256 of the key's DER SubjectPublicKeyInfo
};

// Signs the case's current manifest.json and log head. The case must verify (CaseNotIntact
// otherwise: a signature over a tampered case would vouch for it). Throws InputError naming
// the key file when it is not an Ed25519 private key.
SignatureResult sign_case(const std::filesystem::path& root,
                          const std::filesystem::path& private_key_pem);

// Writes an RFC 3161 time-stamp request (DER, SHA-256 imprint of the log's last line = the
// head, a random nonce, the TSA's certificate asked for) for the user to send to a TSA.
// Returns the head it covers.
std::string write_timestamp_request(const std::filesystem::path& root,
                                    const std::filesystem::path& request_out);
// Stores a TSA's response in anchors/ after checking it is a granted token whose imprint is
// the hash of one of the log's lines (its signature is checked by verify, which has the
// TSA's certificate). Returns the stored file.
std::filesystem::path store_timestamp_response(const std::filesystem::path& root,
                                               const std::filesystem::path& response);

// What the anchors say, added to a verify report: a signature by the key that does not hold,
// or whose head is no longer in the log, and no signature by the key at all, are
// VerifyProblem::Anchor; so is a time stamp that does not verify against the TSA's CA or
// whose head is gone. `notes` says what held (signed at line n, stamped at time t).
void check_signatures(const std::filesystem::path& root,
                      const std::filesystem::path& public_key_pem, VerifyReport& report,
                      std::vector<std::string>& notes);
void check_timestamps(const std::filesystem::path& root, const std::filesystem::path& tsa_ca_pem,
                      VerifyReport& report, std::vector<std::string>& notes);

}  // namespace locard::forensics

// Anchors (anchors.hpp): Ed25519 signatures and RFC 3161 time stamps over a case's log head,
// with OpenSSL's EVP and TS interfaces.
#include <locard/forensics/anchors.hpp>

#include "forensics/case_log.hpp"
#include "forensics/json_util.hpp"

#include <locard/core/atomic_file.hpp>
#include <locard/core/error.hpp>
#include <locard/forensics/integrity.hpp>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <openssl/bio.h>
#include <openssl/bn.h>
#include <openssl/evp.h>
#include <openssl/pem.h>
#include <openssl/rand.h>
#include <openssl/ts.h>
#include <openssl/x509.h>

#include <cstring>
#include <memory>

namespace locard::forensics {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using namespace detail;

template <typename T, void (*Free)(T*)>
struct Deleter {
  void operator()(T* p) const { Free(p); }
};
template <typename T, void (*Free)(T*)>
using Owned = std::unique_ptr<T, Deleter<T, Free>>;
using Pkey = Owned<EVP_PKEY, EVP_PKEY_free>;
using MdCtx = Owned<EVP_MD_CTX, EVP_MD_CTX_free>;
using Bio = Owned<BIO, BIO_free_all>;
using TsReq = Owned<TS_REQ, TS_REQ_free>;
using TsResp = Owned<TS_RESP, TS_RESP_free>;
using TsVerify = Owned<TS_VERIFY_CTX, TS_VERIFY_CTX_free>;
using Store = Owned<X509_STORE, X509_STORE_free>;

constexpr const char* kSignatureFormat = "locard-case-signature/1";

std::string hex(const unsigned char* data, std::size_t n) {
  static constexpr char kHex[] = "0123456789abcdef";
  std::string out;
  for (std::size_t i = 0; i < n; ++i) {
    out.push_back(kHex[data[i] >> 4]);
    out.push_back(kHex[data[i] & 15]);
  }
  return out;
}

std::vector<unsigned char> unhex(const std::string& h) {
  std::vector<unsigned char> out;
  for (std::size_t i = 0; i + 1 < h.size(); i += 2)
    out.push_back(static_cast<unsigned char>(std::stoi(h.substr(i, 2), nullptr, 16)));
  return out;
}

std::string base64(const std::vector<unsigned char>& bytes) {
  std::string out(4 * ((bytes.size() + 2) / 3) + 1, '\0');
  const int n = EVP_EncodeBlock(reinterpret_cast<unsigned char*>(out.data()), bytes.data(),
                                static_cast<int>(bytes.size()));
  out.resize(static_cast<std::size_t>(n));
  return out;
}

std::optional<std::vector<unsigned char>> unbase64(const std::string& text) {
  if (text.empty() || text.size() % 4 != 0) return std::nullopt;
  std::vector<unsigned char> out(text.size() / 4 * 3);
  const int n = EVP_DecodeBlock(out.data(), reinterpret_cast<const unsigned char*>(text.data()),
                                static_cast<int>(text.size()));
  if (n < 0) return std::nullopt;
  std::size_t size = static_cast<std::size_t>(n);
  for (std::size_t i = text.size(); i > 0 && text[i - 1] == '='; --i) --size;  // padding
  out.resize(size);
  return out;
}

Pkey read_key(const fs::path& pem, bool private_key) {
  Bio bio(BIO_new_file(pem.c_str(), "r"));
  if (!bio) throw_input_error(pem, "cannot be read");
  Pkey key(private_key ? PEM_read_bio_PrivateKey(bio.get(), nullptr, nullptr, nullptr)
                       : PEM_read_bio_PUBKEY(bio.get(), nullptr, nullptr, nullptr));
  if (!key)
    throw_input_error(pem, private_key ? "not a PEM private key (make one with `openssl genpkey "
                                         "-algorithm ed25519 -out KEY.pem`)"
                                       : "not a PEM public key (`openssl pkey -in KEY.pem "
                                         "-pubout -out PUB.pem`)");
  if (EVP_PKEY_get_base_id(key.get()) != EVP_PKEY_ED25519)
    throw_input_error(pem, "not an Ed25519 key");
  return key;
}

// SHA-256 of the key's public half as DER SubjectPublicKeyInfo: which key signed.
std::string key_id(EVP_PKEY* key) {
  unsigned char* der = nullptr;
  const int n = i2d_PUBKEY(key, &der);
  if (n <= 0) throw Error("Ed25519: cannot encode the public key");
  const std::string id = sha256_hex(std::span<const std::uint8_t>(der, static_cast<std::size_t>(n)));
  OPENSSL_free(der);
  return id;
}

// The signed text: the head, how many lines it ends, the manifest of the moment.
struct SignedMessage {
  std::string head;
  std::size_t lines = 0;
  std::string manifest_sha256;
  std::string text() const {
    return fmt::format("{}\nlog_head_sha256 {}\nlog_lines {}\nmanifest_sha256 {}\n",
                       kSignatureFormat, head, lines, manifest_sha256);
  }
};

std::optional<SignedMessage> parse_message(const std::string& text) {
  SignedMessage m;
  char head[65] = {}, manifest[65] = {}, format[64] = {};
  unsigned long lines = 0;
  if (std::sscanf(text.c_str(), "%63s\nlog_head_sha256 %64s\nlog_lines %lu\nmanifest_sha256 %64s",
                  format, head, &lines, manifest) != 4 ||
      std::string(format) != kSignatureFormat)
    return std::nullopt;
  m.head = head;
  m.lines = lines;
  m.manifest_sha256 = manifest;
  if (m.text() != text) return std::nullopt;  // nothing else in it
  return m;
}

std::vector<fs::path> anchor_files(const fs::path& root, std::string_view prefix,
                                   std::string_view extension) {
  std::vector<fs::path> out;
  for (const std::string& rel : list_files_recursive(root / kAnchors)) {
    const fs::path p(rel);
    if (p.filename().string().rfind(prefix, 0) == 0 && p.extension() == extension)
      out.push_back(root / kAnchors / p);
  }
  return out;
}

void write_bytes(const fs::path& path, const std::string& bytes) {
  fs::create_directories(path.parent_path());
  AtomicFile f(path, true);
  f.stream() << bytes;
  f.commit();
}

// One signature file checked against the trusted key; false when made by another key.
bool check_one_signature(const fs::path& root, const fs::path& file, EVP_PKEY* key,
                         const std::string& id, VerifyReport& report,
                         std::vector<std::string>& notes) {
  const std::string rel = fs::relative(file, root).generic_string();
  auto problem = [&](const std::string& what) {
    report.problems.push_back({VerifyProblem::Kind::Anchor, rel, what});
  };
  json sig;
  try {
    sig = parse_json_file(file);
  } catch (const InputError& e) {
    problem(e.what());
    return true;
  }
  // Fields of a file anyone could have written: a wrong type reads as absent (and then the
  // signature does not hold), never as a raw JSON exception.
  const auto text = [&sig](const char* field) {
    const auto it = sig.is_object() ? sig.find(field) : sig.end();
    return it != sig.end() && it->is_string() ? it->get<std::string>() : std::string();
  };
  if (!sig.is_object() || text("public_key_sha256") != id) return false;
  const std::string message = text("message");
  const auto bytes = unbase64(text("signature_base64"));
  MdCtx ctx(EVP_MD_CTX_new());
  const bool valid =
      bytes && ctx && EVP_DigestVerifyInit(ctx.get(), nullptr, nullptr, nullptr, key) == 1 &&
      EVP_DigestVerify(ctx.get(), bytes->data(), bytes->size(),
                       reinterpret_cast<const unsigned char*>(message.data()), message.size()) == 1;
  const auto m = parse_message(message);
  if (!valid || !m) {
    problem("the signature does not hold for its message under this key (the file was edited)");
    return true;
  }
  const auto line = find_log_line(root, m->head);
  if (!line || *line + 1 != m->lines) {
    problem(fmt::format("the signed log head {} (line {}) is no longer in the log: the steps up "
                        "to it were rewritten or removed",
                        m->head, m->lines));
    return true;
  }
  if (*line + 1 == report.log_lines) {
    const std::string manifest = sha256_file(root / kManifest);
    if (manifest != m->manifest_sha256)
      problem(fmt::format("manifest.json hashes to {}, the signature covers {}", manifest,
                          m->manifest_sha256));
    else
      notes.push_back(fmt::format("{}: signature holds for the case as it is (log line {})", rel,
                                  m->lines));
  } else {
    notes.push_back(fmt::format("{}: signature holds for log line {}; {} step(s) logged after it",
                                rel, m->lines, report.log_lines - m->lines));
  }
  return true;
}

std::string generalized_time(const ASN1_GENERALIZEDTIME* t) {
  Bio mem(BIO_new(BIO_s_mem()));
  if (!t || !mem || ASN1_TIME_print(mem.get(), t) != 1) return "?";
  char* data = nullptr;
  const long n = BIO_get_mem_data(mem.get(), &data);
  return std::string(data, static_cast<std::size_t>(n));
}

TsResp read_response(const fs::path& file) {
  const std::string bytes = read_text(file);
  const unsigned char* p = reinterpret_cast<const unsigned char*>(bytes.data());
  TsResp resp(d2i_TS_RESP(nullptr, &p, static_cast<long>(bytes.size())));
  if (!resp) throw_input_error(file, "not an RFC 3161 time-stamp response (DER)");
  return resp;
}

// The token's imprint as hex, after checking it is a SHA-256 one.
std::string token_imprint(const fs::path& file, TS_RESP* resp) {
  TS_TST_INFO* info = TS_RESP_get_tst_info(resp);
  if (!info) throw_input_error(file, "the response holds no time-stamp token (not granted)");
  TS_MSG_IMPRINT* imprint = TS_TST_INFO_get_msg_imprint(info);
  const ASN1_OBJECT* algorithm = nullptr;
  X509_ALGOR_get0(&algorithm, nullptr, nullptr, TS_MSG_IMPRINT_get_algo(imprint));
  if (OBJ_obj2nid(algorithm) != NID_sha256)
    throw_input_error(file, "the token's imprint is not SHA-256");
  const ASN1_OCTET_STRING* digest = TS_MSG_IMPRINT_get_msg(imprint);
  return hex(ASN1_STRING_get0_data(digest), static_cast<std::size_t>(ASN1_STRING_length(digest)));
}

}  // namespace

SignatureResult sign_case(const fs::path& root, const fs::path& private_key_pem) {
  const Pkey key = read_key(private_key_pem, true);
  const CaseFolder folder = CaseFolder::open(root, CaseAccess::Change);  // verified
  SignedMessage m;
  m.head = log_head_sha256(root);
  m.lines = log_lines(root).size();
  m.manifest_sha256 = sha256_file(root / kManifest);
  const std::string text = m.text();
  MdCtx ctx(EVP_MD_CTX_new());
  std::size_t length = 0;
  if (!ctx || EVP_DigestSignInit(ctx.get(), nullptr, nullptr, nullptr, key.get()) != 1 ||
      EVP_DigestSign(ctx.get(), nullptr, &length,
                     reinterpret_cast<const unsigned char*>(text.data()), text.size()) != 1)
    throw Error("Ed25519: OpenSSL could not start the signature");
  std::vector<unsigned char> signature(length);
  if (EVP_DigestSign(ctx.get(), signature.data(), &length,
                     reinterpret_cast<const unsigned char*>(text.data()), text.size()) != 1)
    throw Error("Ed25519: OpenSSL could not sign");
  signature.resize(length);
  SignatureResult r;
  r.log_head_sha256 = m.head;
  r.public_key_sha256 = key_id(key.get());
  r.file = root / kAnchors / fmt::format("signature-{}-{}.json", m.head.substr(0, 16),
                                         r.public_key_sha256.substr(0, 8));
  const json out = {{"format", kSignatureFormat},
                    {"algorithm", "Ed25519"},
                    {"message", text},
                    {"signature_base64", base64(signature)},
                    {"public_key_sha256", r.public_key_sha256},
                    {"signed_at", utc_now_iso8601()}};
  write_bytes(r.file, out.dump(1) + "\n");
  return r;
}

void check_signatures(const fs::path& root, const fs::path& public_key_pem, VerifyReport& report,
                      std::vector<std::string>& notes) {
  const Pkey key = read_key(public_key_pem, false);
  const std::string id = key_id(key.get());
  std::size_t by_key = 0;
  for (const fs::path& file : anchor_files(root, "signature-", ".json"))
    by_key += check_one_signature(root, file, key.get(), id, report, notes);
  if (by_key == 0)
    report.problems.push_back({VerifyProblem::Kind::Anchor, kAnchors,
                               fmt::format("no signature by the key {} (sha256 {})",
                                           public_key_pem.string(), id)});
}

std::string write_timestamp_request(const fs::path& root, const fs::path& request_out) {
  const CaseFolder folder = CaseFolder::open(root, CaseAccess::Change);  // verified
  const std::string head = log_head_sha256(root);
  if (head.empty()) throw_input_error(root, "the case's log is empty: nothing to time-stamp");
  std::vector<unsigned char> digest = unhex(head);
  TsReq req(TS_REQ_new());
  Owned<TS_MSG_IMPRINT, TS_MSG_IMPRINT_free> imprint(TS_MSG_IMPRINT_new());
  Owned<X509_ALGOR, X509_ALGOR_free> algorithm(X509_ALGOR_new());
  Owned<BIGNUM, BN_free> nonce_bn(BN_new());
  if (!req || !imprint || !algorithm || !nonce_bn ||
      X509_ALGOR_set0(algorithm.get(), OBJ_nid2obj(NID_sha256), V_ASN1_NULL, nullptr) != 1 ||
      TS_MSG_IMPRINT_set_algo(imprint.get(), algorithm.get()) != 1 ||
      TS_MSG_IMPRINT_set_msg(imprint.get(), digest.data(), static_cast<int>(digest.size())) != 1 ||
      TS_REQ_set_version(req.get(), 1) != 1 ||
      TS_REQ_set_msg_imprint(req.get(), imprint.get()) != 1 ||
      BN_rand(nonce_bn.get(), 64, BN_RAND_TOP_ANY, BN_RAND_BOTTOM_ANY) != 1)
    throw Error("RFC 3161: OpenSSL could not build the request");
  Owned<ASN1_INTEGER, ASN1_INTEGER_free> nonce(BN_to_ASN1_INTEGER(nonce_bn.get(), nullptr));
  if (!nonce || TS_REQ_set_nonce(req.get(), nonce.get()) != 1 ||
      TS_REQ_set_cert_req(req.get(), 1) != 1)
    throw Error("RFC 3161: OpenSSL could not build the request");
  unsigned char* der = nullptr;
  const int n = i2d_TS_REQ(req.get(), &der);
  if (n <= 0) throw Error("RFC 3161: OpenSSL could not encode the request");
  const std::string bytes(reinterpret_cast<const char*>(der), static_cast<std::size_t>(n));
  OPENSSL_free(der);
  write_bytes(fs::absolute(request_out), bytes);
  return head;
}

fs::path store_timestamp_response(const fs::path& root, const fs::path& response) {
  const CaseFolder folder = CaseFolder::open(root, CaseAccess::Read);  // held while storing
  const TsResp resp = read_response(response);
  const long status = ASN1_INTEGER_get(TS_STATUS_INFO_get0_status(TS_RESP_get_status_info(resp.get())));
  if (status != 0 && status != 1)  // granted, granted with modifications
    throw_input_error(response, fmt::format("the TSA did not grant the time stamp (status {})", status));
  const std::string head = token_imprint(response, resp.get());
  if (!find_log_line(root, head))
    throw_input_error(response, fmt::format("the token stamps {}, which is no line of {}'s log",
                                            head, root.string()));
  const fs::path stored = root / kAnchors / fmt::format("timestamp-{}.tsr", head.substr(0, 16));
  write_bytes(stored, read_text(response));
  return stored;
}

void check_timestamps(const fs::path& root, const fs::path& tsa_ca_pem, VerifyReport& report,
                      std::vector<std::string>& notes) {
  const std::vector<fs::path> files = anchor_files(root, "timestamp-", ".tsr");
  if (files.empty())
    report.problems.push_back({VerifyProblem::Kind::Anchor, kAnchors, "no time stamp stored"});
  for (const fs::path& file : files) {
    const std::string rel = fs::relative(file, root).generic_string();
    auto problem = [&](const std::string& what) {
      report.problems.push_back({VerifyProblem::Kind::Anchor, rel, what});
    };
    TsResp resp;
    std::string head;
    try {
      resp = read_response(file);
      head = token_imprint(file, resp.get());
    } catch (const InputError& e) {
      problem(e.what());
      continue;
    }
    const auto line = find_log_line(root, head);
    if (!line) {
      problem(fmt::format("the stamped log head {} is no longer in the log: the steps up to it "
                          "were rewritten or removed", head));
      continue;
    }
    Store store(X509_STORE_new());
    if (!store || X509_STORE_load_file(store.get(), tsa_ca_pem.c_str()) != 1)
      throw_input_error(tsa_ca_pem, "not a PEM certificate file");
    TsVerify ctx(TS_VERIFY_CTX_new());
    const std::vector<unsigned char> digest = unhex(head);
    auto* imprint = static_cast<unsigned char*>(OPENSSL_malloc(digest.size()));
    std::memcpy(imprint, digest.data(), digest.size());
    TS_VERIFY_CTX_set_flags(ctx.get(), TS_VFY_VERSION | TS_VFY_SIGNATURE | TS_VFY_IMPRINT);
    TS_VERIFY_CTX_set_imprint(ctx.get(), imprint, static_cast<long>(digest.size()));  // owns it
    TS_VERIFY_CTX_set_store(ctx.get(), store.release());                            // owns it
    if (TS_RESP_verify_response(ctx.get(), resp.get()) != 1) {
      problem(fmt::format("the time stamp does not verify against {} (a forged or edited token, "
                          "or another TSA)", tsa_ca_pem.string()));
      continue;
    }
    notes.push_back(fmt::format("{}: log line {} existed at {} (RFC 3161, {})", rel, *line + 1,
                                generalized_time(TS_TST_INFO_get_time(TS_RESP_get_tst_info(resp.get()))),
                                tsa_ca_pem.filename().string()));
  }
}

}  // namespace locard::forensics

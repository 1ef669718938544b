#pragma once
// SHA-256 of bytes and files (OpenSSL's EVP interface underneath, hidden here), as lowercase
// hex. Every input a case is built from and every file it holds is recorded by this digest.

#include <cstdint>
#include <filesystem>
#include <span>
#include <string>
#include <string_view>

namespace locard::forensics {

std::string sha256_hex(std::span<const std::uint8_t> bytes);
std::string sha256_hex(std::string_view text);
// Streams the file; throws InputError naming it when it cannot be read.
std::string sha256_file(const std::filesystem::path& path);

}  // namespace locard::forensics

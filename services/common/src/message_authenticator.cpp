#include "mfot/service/message_authenticator.hpp"

#include <openssl/core_names.h>
#include <openssl/crypto.h>
#include <openssl/evp.h>
#include <sys/stat.h>

#include <array>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iterator>
#include <stdexcept>

#include "mfot/service/config.hpp"

namespace mfot::service {

namespace {

std::int64_t read_int64(const std::uint8_t* p) {
  std::uint64_t bits = 0;
  for (int i = 0; i < 8; ++i) bits = (bits << 8) | p[i];
  return static_cast<std::int64_t>(bits);
}

void write_int64(std::uint8_t* p, std::int64_t value) {
  auto bits = static_cast<std::uint64_t>(value);
  for (int i = 7; i >= 0; --i) {
    p[i] = static_cast<std::uint8_t>(bits & 0xFF);
    bits >>= 8;
  }
}

}  // namespace

const char* verdict_name(Verdict verdict) {
  switch (verdict) {
    case Verdict::kAccepted:
      return "accepted";
    case Verdict::kNoEnvelope:
      return "no envelope";
    case Verdict::kForeign:
      return "foreign";
    case Verdict::kForged:
      return "forged";
    case Verdict::kReplayed:
      return "replayed";
  }
  return "?";
}

std::vector<std::uint8_t> load_group_key(const std::string& path) {
  const std::string where = "group.key_file '" + path + "'";
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) throw ConfigError(where + ": cannot stat: " + std::strerror(errno));
  if (!S_ISREG(st.st_mode)) throw ConfigError(where + ": not a regular file");
  if ((st.st_mode & 077) != 0) {
    char mode[8];
    std::snprintf(mode, sizeof(mode), "%04o", static_cast<unsigned>(st.st_mode & 07777));
    throw ConfigError(where + ": mode " + mode +
                      " lets the group or others access the key; it must be readable by its owner only (chmod 600)");
  }
  if (st.st_size < static_cast<off_t>(kMinKeyBytes) || st.st_size > static_cast<off_t>(kMaxKeyBytes)) {
    throw ConfigError(where + ": " + std::to_string(st.st_size) + " bytes; a key has " + std::to_string(kMinKeyBytes) +
                      " to " + std::to_string(kMaxKeyBytes) + " (e.g. head -c 32 /dev/urandom > key)");
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) throw ConfigError(where + ": cannot open: " + std::strerror(errno));
  std::vector<std::uint8_t> key((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (key.size() < kMinKeyBytes) throw ConfigError(where + ": shorter than " + std::to_string(kMinKeyBytes) + " bytes");
  return key;
}

struct MessageAuthenticator::MacAlgorithm {
  EVP_MAC* mac = nullptr;
  ~MacAlgorithm() { EVP_MAC_free(mac); }
};

MessageAuthenticator::MessageAuthenticator(std::int64_t group_id, std::int64_t sender, std::vector<std::uint8_t> key)
    : group_id_(group_id), sender_(sender), key_(std::move(key)) {
  if (group_id < 1 || group_id > kMaxGroupId) {
    throw std::invalid_argument("MessageAuthenticator: group id " + std::to_string(group_id) + " out of [1, 2^53]");
  }
  if (sender < 1) throw std::invalid_argument("MessageAuthenticator: sender must be > 0");
  if (!key_.empty()) {
    if (key_.size() < kMinKeyBytes) throw std::invalid_argument("MessageAuthenticator: key shorter than 32 bytes");
    algorithm_ = std::make_shared<MacAlgorithm>();
    algorithm_->mac = EVP_MAC_fetch(nullptr, "HMAC", nullptr);
    if (algorithm_->mac == nullptr) throw std::runtime_error("OpenSSL: HMAC is not available");
  }
}

void MessageAuthenticator::mac(const std::uint8_t* data, std::size_t size,
                               std::uint8_t out[envelope::kMacBytes]) const {
  EVP_MAC_CTX* ctx = EVP_MAC_CTX_new(algorithm_->mac);
  if (ctx == nullptr) throw std::runtime_error("OpenSSL: EVP_MAC_CTX_new failed");
  char digest[] = "SHA256";
  const OSSL_PARAM params[] = {OSSL_PARAM_construct_utf8_string(OSSL_MAC_PARAM_DIGEST, digest, 0),
                               OSSL_PARAM_construct_end()};
  static const std::array<std::uint8_t, envelope::kMacBytes> zeros{};
  std::size_t written = 0;
  const bool ok = EVP_MAC_init(ctx, key_.data(), key_.size(), params) == 1 &&
                  EVP_MAC_update(ctx, data, envelope::kMacOffset) == 1 &&
                  EVP_MAC_update(ctx, zeros.data(), zeros.size()) == 1 &&
                  EVP_MAC_update(ctx, data + envelope::kEnd, size - envelope::kEnd) == 1 &&
                  EVP_MAC_final(ctx, out, &written, envelope::kMacBytes) == 1 && written == envelope::kMacBytes;
  EVP_MAC_CTX_free(ctx);
  if (!ok) throw std::runtime_error("OpenSSL: HMAC-SHA256 failed");
}

bool MessageAuthenticator::stamp(std::uint8_t* data, std::size_t size) {
  if (data == nullptr || size < envelope::kEnd) return false;
  std::int64_t sequence = 0;
  {
    std::lock_guard lock(mutex_);
    sequence = next_sequence_++;
  }
  write_int64(data + envelope::kGroupOffset, group_id_);
  write_int64(data + envelope::kSenderOffset, sender_);
  write_int64(data + envelope::kSequenceOffset, sequence);
  if (authenticated()) {
    mac(data, size, data + envelope::kMacOffset);
  } else {
    std::memset(data + envelope::kMacOffset, 0, envelope::kMacBytes);
  }
  return true;
}

Verdict MessageAuthenticator::verify(const std::string& channel, const std::uint8_t* data, std::size_t size,
                                     std::int64_t now_utime) {
  if (data == nullptr || size < envelope::kEnd) return Verdict::kNoEnvelope;
  if (read_int64(data + envelope::kGroupOffset) != group_id_) {
    std::lock_guard lock(mutex_);
    ++counts_.foreign;
    return Verdict::kForeign;
  }
  if (!authenticated()) return Verdict::kAccepted;
  std::array<std::uint8_t, envelope::kMacBytes> expected{};
  mac(data, size, expected.data());
  if (CRYPTO_memcmp(expected.data(), data + envelope::kMacOffset, envelope::kMacBytes) != 0) {
    std::lock_guard lock(mutex_);
    ++counts_.forged;
    return Verdict::kForged;
  }
  const std::int64_t sender = read_int64(data + envelope::kSenderOffset);
  const std::int64_t sequence = read_int64(data + envelope::kSequenceOffset);
  const std::int64_t utime = read_int64(data + 8);
  std::lock_guard lock(mutex_);
  if (max_age_us_ > 0 && (utime < now_utime - max_age_us_ || utime > now_utime + max_age_us_)) {
    ++counts_.replayed;
    return Verdict::kReplayed;
  }
  ++clock_;
  auto it = last_.find({sender, channel});
  if (sequence < 1 || (it != last_.end() && sequence <= it->second.sequence)) {
    ++counts_.replayed;
    return Verdict::kReplayed;
  }
  if (it != last_.end()) {
    it->second = {sequence, clock_};
    return Verdict::kAccepted;
  }
  if (last_.size() >= kMaxRememberedSenders) {
    auto oldest = last_.begin();
    for (auto i = last_.begin(); i != last_.end(); ++i) {
      if (i->second.heard < oldest->second.heard) oldest = i;
    }
    last_.erase(oldest);
  }
  last_.emplace(std::make_pair(sender, channel), Seen{sequence, clock_});
  return Verdict::kAccepted;
}

AuthCounts MessageAuthenticator::counts() const {
  std::lock_guard lock(mutex_);
  return counts_;
}

}  // namespace mfot::service

// MessageAuthenticator (issue 55) on encoded messages, no LCM sockets: stamping, the group check,
// HMAC-SHA256, replay, the key file's mode and length; and SenderLock.

#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "encoded_message.hpp"
#include "mfot/heartbeat_t.hpp"
#include "mfot/poses_t.hpp"
#include "mfot/service/config.hpp"
#include "mfot/service/message_authenticator.hpp"
#include "mfot/service/sender_lock.hpp"

namespace mfot::service {
namespace {

using testing::Bytes;
using testing::encode;

constexpr std::int64_t kNow = 1'700'000'000'000'000;

std::vector<std::uint8_t> key_of(char fill) { return std::vector<std::uint8_t>(32, static_cast<std::uint8_t>(fill)); }

Bytes sample_heartbeat() {
  heartbeat_t hb{};
  hb.utime = kNow;
  hb.worker_id = 3;
  hb.instance = 42;
  hb.host = "host";
  hb.object_id = 7;
  hb.last_frame_seq = 11;
  return encode(hb);
}

TEST(MessageAuthenticator, StampedMessageIsAcceptedAndDecodesWithItsEnvelope) {
  MessageAuthenticator sender(5, 1001, key_of('k'));
  MessageAuthenticator receiver(5, 2002, key_of('k'));
  Bytes message = sample_heartbeat();
  ASSERT_TRUE(sender.stamp(message));
  EXPECT_EQ(receiver.verify("MFOT_HEARTBEAT", message, kNow), Verdict::kAccepted);
  heartbeat_t decoded;
  ASSERT_EQ(decoded.decode(message.data(), 0, static_cast<int>(message.size())), static_cast<int>(message.size()));
  EXPECT_EQ(decoded.envelope.group_id, 5);
  EXPECT_EQ(decoded.envelope.sender, 1001);
  EXPECT_EQ(decoded.envelope.sequence, 1);
  EXPECT_EQ(decoded.object_id, 7);
  EXPECT_EQ(receiver.counts().forged + receiver.counts().foreign + receiver.counts().replayed, 0);
}

TEST(MessageAuthenticator, MacIsThePythonOne) {
  // tests/python/test_mfot_auth.py stamps the same heartbeat with the same key, group and sender with
  // scripts/mfot_auth.py (hmac, hashlib) and expects this MAC too.
  MessageAuthenticator sender(5, 1001, key_of('k'));
  Bytes message = sample_heartbeat();
  ASSERT_TRUE(sender.stamp(message));
  std::string hex;
  for (std::size_t i = envelope::kMacOffset; i < envelope::kEnd; ++i) {
    static const char* digits = "0123456789abcdef";
    hex += digits[message[i] >> 4];
    hex += digits[message[i] & 15];
  }
  EXPECT_EQ(hex, "eb9899a4c3f005d2800b19818742eb5bc11cf56265c7c3c80c3ccba57ecc8c04");
}

TEST(MessageAuthenticator, EveryAlteredByteIsForged) {
  MessageAuthenticator sender(5, 1001, key_of('k'));
  Bytes message = sample_heartbeat();
  ASSERT_TRUE(sender.stamp(message));
  for (std::size_t i = 0; i < message.size(); ++i) {
    if (i >= envelope::kGroupOffset && i < envelope::kGroupOffset + 8) continue;  // the group: foreign, below
    MessageAuthenticator receiver(5, 2002, key_of('k'));
    Bytes altered = message;
    altered[i] ^= 0x01;
    EXPECT_EQ(receiver.verify("MFOT_HEARTBEAT", altered, kNow), Verdict::kForged) << "byte " << i;
    EXPECT_EQ(receiver.counts().forged, 1);
  }
}

TEST(MessageAuthenticator, WrongKeyIsForged) {
  MessageAuthenticator sender(5, 1001, key_of('a'));
  MessageAuthenticator receiver(5, 2002, key_of('b'));
  Bytes message = sample_heartbeat();
  ASSERT_TRUE(sender.stamp(message));
  EXPECT_EQ(receiver.verify("MFOT_HEARTBEAT", message, kNow), Verdict::kForged);
  // Unsigned (a group without a key talking to one with a key) is forged too.
  MessageAuthenticator unkeyed(5, 1003, {});
  Bytes plain = sample_heartbeat();
  ASSERT_TRUE(unkeyed.stamp(plain));
  EXPECT_EQ(receiver.verify("MFOT_HEARTBEAT", plain, kNow), Verdict::kForged);
  EXPECT_EQ(receiver.counts().forged, 2);
}

TEST(MessageAuthenticator, OtherGroupIsForeign) {
  MessageAuthenticator other(6, 1001, key_of('k'));
  MessageAuthenticator receiver(5, 2002, key_of('k'));
  Bytes message = sample_heartbeat();
  ASSERT_TRUE(other.stamp(message));
  EXPECT_EQ(receiver.verify("MFOT_HEARTBEAT", message, kNow), Verdict::kForeign);
  EXPECT_EQ(receiver.counts().foreign, 1);
  EXPECT_EQ(receiver.counts().forged, 0);
}

TEST(MessageAuthenticator, ReplayIsDroppedPerSenderAndChannel) {
  MessageAuthenticator sender(5, 1001, key_of('k'));
  MessageAuthenticator receiver(5, 2002, key_of('k'));
  Bytes first = sample_heartbeat();
  Bytes second = sample_heartbeat();
  ASSERT_TRUE(sender.stamp(first));
  ASSERT_TRUE(sender.stamp(second));
  EXPECT_EQ(receiver.verify("MFOT_HEARTBEAT", second, kNow), Verdict::kAccepted);
  EXPECT_EQ(receiver.verify("MFOT_HEARTBEAT", second, kNow), Verdict::kReplayed);  // the same again
  EXPECT_EQ(receiver.verify("MFOT_HEARTBEAT", first, kNow), Verdict::kReplayed);   // an older one
  // Sequences are per channel on the receiving side: the same sender's first message elsewhere is new.
  EXPECT_EQ(receiver.verify("MFOT_OTHER", first, kNow), Verdict::kAccepted);
  EXPECT_EQ(receiver.counts().replayed, 2);
}

TEST(MessageAuthenticator, MessageOlderThanTheMaximumAgeIsReplayed) {
  MessageAuthenticator sender(5, 1001, key_of('k'));
  MessageAuthenticator receiver(5, 2002, key_of('k'));
  receiver.set_max_age_us(30'000'000);
  Bytes message = sample_heartbeat();  // utime kNow
  ASSERT_TRUE(sender.stamp(message));
  EXPECT_EQ(receiver.verify("MFOT_HEARTBEAT", message, kNow + 31'000'000), Verdict::kReplayed);
  EXPECT_EQ(receiver.verify("MFOT_HEARTBEAT", message, kNow + 29'000'000), Verdict::kAccepted);
}

TEST(MessageAuthenticator, WithoutKeyOnlyTheGroupIsChecked) {
  MessageAuthenticator sender(5, 1001, {});
  MessageAuthenticator receiver(5, 2002, {});
  Bytes message = sample_heartbeat();
  ASSERT_TRUE(sender.stamp(message));
  for (std::size_t i = envelope::kMacOffset; i < envelope::kEnd; ++i) EXPECT_EQ(message[i], 0) << "mac byte " << i;
  EXPECT_EQ(receiver.verify("MFOT_HEARTBEAT", message, kNow), Verdict::kAccepted);
  EXPECT_EQ(receiver.verify("MFOT_HEARTBEAT", message, kNow), Verdict::kAccepted);  // no replay check either
  MessageAuthenticator other(9, 1001, {});
  Bytes foreign = sample_heartbeat();
  ASSERT_TRUE(other.stamp(foreign));
  EXPECT_EQ(receiver.verify("MFOT_HEARTBEAT", foreign, kNow), Verdict::kForeign);
  // Nothing to check in a message too short for an envelope: the caller counts it as malformed.
  const Bytes tiny(10, 0);
  EXPECT_EQ(receiver.verify("MFOT_HEARTBEAT", tiny, kNow), Verdict::kNoEnvelope);
}

TEST(MessageAuthenticator, TheEnvelopeSitsAtOneOffsetInEveryType) {
  MessageAuthenticator sender(77, 1001, key_of('k'));
  poses_t poses{};
  poses.utime = kNow;
  poses.frame_seq = 4;
  Bytes message = encode(poses);
  ASSERT_TRUE(sender.stamp(message));
  poses_t decoded;
  ASSERT_GT(decoded.decode(message.data(), 0, static_cast<int>(message.size())), 0);
  EXPECT_EQ(decoded.envelope.group_id, 77);
  EXPECT_EQ(decoded.envelope.sequence, 1);
  EXPECT_EQ(decoded.frame_seq, 4);
}

class KeyFile : public ::testing::Test {
 protected:
  void SetUp() override { path_ = std::filesystem::temp_directory_path() / ("mfot_key_" + std::to_string(getpid())); }
  void TearDown() override { std::filesystem::remove(path_); }
  void write(const std::string& bytes, mode_t mode) {
    std::ofstream(path_, std::ios::binary) << bytes;
    ASSERT_EQ(::chmod(path_.c_str(), mode), 0);
  }
  std::filesystem::path path_;
};

TEST_F(KeyFile, OwnerOnlyKeyIsRead) {
  write(std::string(32, 'x'), 0600);
  EXPECT_EQ(load_group_key(path_.string()), key_of('x'));
}

TEST_F(KeyFile, KeyOthersMayReadIsRefused) {
  write(std::string(32, 'x'), 0644);
  try {
    load_group_key(path_.string());
    FAIL() << "a 0644 key was accepted";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("mode 0644"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find(path_.string()), std::string::npos) << e.what();
  }
  write(std::string(32, 'x'), 0640);
  EXPECT_THROW(load_group_key(path_.string()), ConfigError);
}

TEST_F(KeyFile, ShortOrMissingKeyIsRefused) {
  write(std::string(31, 'x'), 0600);
  EXPECT_THROW(load_group_key(path_.string()), ConfigError);
  EXPECT_THROW(load_group_key(path_.string() + ".absent"), ConfigError);
}

TEST(SenderLock, TakesTheFirstSenderUntilItFallsSilent) {
  using namespace std::chrono_literals;
  SenderLock lock(3s);
  const SenderLock::Clock::time_point t0{};
  EXPECT_TRUE(lock.accepts(10, t0));
  EXPECT_FALSE(lock.accepts(20, t0 + 1s));  // another merger while ours is alive
  lock.heard(10, t0 + 2s);                  // its status keeps it
  EXPECT_FALSE(lock.accepts(20, t0 + 4s));
  EXPECT_TRUE(lock.accepts(10, t0 + 4s));
  EXPECT_TRUE(lock.accepts(20, t0 + 8s));  // silent 4 s: a restarted merger is adopted
  EXPECT_EQ(lock.owner(), 20);
}

}  // namespace
}  // namespace mfot::service

// idl/saccade.idl is what saccade writes: the committed file is the one
// `saccade idl` derives from the messages' fields, and the types another DDS
// program generates from it with fastddsgen read saccade's CDR bytes and
// write the very same bytes back (and saccade reads theirs).
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

#include <fastcdr/Cdr.h>
#include <fastcdr/FastBuffer.h>
#include <fastdds/rtps/common/SerializedPayload.h>

#include "fill_every_field.hpp"
#include "saccade/cdr.hpp"
#include "saccade/schema.hpp"
#include "saccadePubSubTypes.h"

namespace saccade {
namespace {

using eprosima::fastrtps::rtps::SerializedPayload_t;

std::string committed_idl() {
  std::ifstream in(SACCADE_SOURCE_DIR "/idl/saccade.idl");
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

TEST(Idl, TheCommittedFileIsWhatSaccadeWrites) {
  EXPECT_EQ(committed_idl(), cdr::idl()) << "run: saccade idl > idl/saccade.idl";
}

// saccade's bytes -> the generated type -> its bytes: equal, and read back by saccade.
template <class M, class P>
void expect_same_bytes_both_ways(int seed) {
  M in;
  in.timestamp_ns = 1'700'000'000'000'000'000 + seed;
  in.origin_ns = -seed;
  in.frame_id = 1000 + seed;
  test::fill_every_field(in, seed);
  if constexpr (requires { in.retina; }) {
    auto retina = std::make_shared<Retina>();
    test::fill_every_field(*retina, seed + 50);
    in.retina = retina;
  }
  cdr::Envelope envelope{.flags = 1, .mailbox = 77, .post = 78};
  std::vector<uint8_t> ours;
  cdr::write(in, envelope, ours);

  P type;
  EXPECT_EQ(type.getName(), cdr::idl_type_name(M::kTypeName));
  SerializedPayload_t payload(static_cast<uint32_t>(ours.size()));
  std::copy(ours.begin(), ours.end(), payload.data);
  payload.length = static_cast<uint32_t>(ours.size());
  auto* generated = static_cast<typename P::type*>(type.createData());
  ASSERT_TRUE(type.deserialize(&payload, generated)) << M::kTypeName;
  EXPECT_EQ(generated->stamp().frame_id(), in.frame_id);
  EXPECT_EQ(generated->stamp().post(), 78u);

  SerializedPayload_t theirs(type.getSerializedSizeProvider(generated)());
  ASSERT_TRUE(type.serialize(generated, &theirs));
  type.deleteData(generated);
  ASSERT_EQ(theirs.length, ours.size()) << M::kTypeName;
  EXPECT_TRUE(std::equal(ours.begin(), ours.end(), theirs.data)) << M::kTypeName << ": the bytes differ";

  M out;
  cdr::Envelope back;
  const Status read = cdr::read(theirs.data, theirs.length, out, back);
  ASSERT_TRUE(read.ok()) << read.message();
  std::string a, b;
  append_json(a, in);
  append_json(b, out);
  EXPECT_EQ(a, b) << M::kTypeName;
  EXPECT_EQ(back.flags, 1u);
  EXPECT_EQ(back.mailbox, 77u);
}

template <class M, class P>
void expect_interoperable() {
  for (int seed : {1, 2, 7}) expect_same_bytes_both_ways<M, P>(seed);
}

TEST(Idl, FastddsgenTypesOfTheIdlReadAndWriteSaccadesBytes) {
  expect_interoperable<Image, saccade_idl::ImagePubSubType>();
  expect_interoperable<Retina, saccade_idl::RetinaPubSubType>();
  expect_interoperable<FeatureMaps, saccade_idl::FeatureMapsPubSubType>();
  expect_interoperable<Motion, saccade_idl::MotionPubSubType>();
  expect_interoperable<Region, saccade_idl::RegionPubSubType>();
  expect_interoperable<StereoFixation, saccade_idl::StereoFixationPubSubType>();
  expect_interoperable<GazeRequest, saccade_idl::GazeRequestPubSubType>();
  expect_interoperable<JointState, saccade_idl::JointStatePubSubType>();
  expect_interoperable<JointTargets, saccade_idl::JointTargetsPubSubType>();
  expect_interoperable<HeadPose, saccade_idl::HeadPosePubSubType>();
  expect_interoperable<FoveaState, saccade_idl::FoveaStatePubSubType>();
  expect_interoperable<Classification, saccade_idl::ClassificationPubSubType>();
  expect_interoperable<CanFrames, saccade_idl::CanFramesPubSubType>();
  EXPECT_EQ(described_message_types().size(), 13u) << "a new type needs its line here";
}

// A big-endian writer's bytes (encapsulation 00 00) read the same.
TEST(Idl, BigEndianBytesReadTheSame) {
  Region in;
  in.frame_id = 5;
  test::fill_every_field(in, 3);
  saccade_idl::RegionPubSubType type;
  saccade_idl::Region generated;
  std::vector<uint8_t> ours;
  cdr::write(in, cdr::Envelope{}, ours);
  SerializedPayload_t payload(static_cast<uint32_t>(ours.size()));
  std::copy(ours.begin(), ours.end(), payload.data);
  payload.length = static_cast<uint32_t>(ours.size());
  ASSERT_TRUE(type.deserialize(&payload, &generated));
  std::vector<char> big(ours.size() + 64);
  eprosima::fastcdr::FastBuffer buffer(big.data(), big.size());
  eprosima::fastcdr::Cdr cdr(buffer, eprosima::fastcdr::Cdr::BIG_ENDIANNESS, eprosima::fastcdr::Cdr::DDS_CDR);
  cdr.serialize_encapsulation();
  generated.serialize(cdr);
  ASSERT_EQ(big[1], 0) << "big-endian encapsulation";
  Region out;
  cdr::Envelope envelope;
  const Status read =
      cdr::read(reinterpret_cast<const uint8_t*>(big.data()), cdr.getSerializedDataLength(), out, envelope);
  ASSERT_TRUE(read.ok()) << read.message();
  std::string a, b;
  append_json(a, in);
  append_json(b, out);
  EXPECT_EQ(a, b);
}

}  // namespace
}  // namespace saccade

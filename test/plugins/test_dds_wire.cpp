// Every message type through its IDL type's CDR bytes and back: bit-exact.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fastdds/rtps/common/SerializedPayload.h>
#include <opencv2/imgproc.hpp>

#include "edge_codec.hpp"
#include "fill_every_field.hpp"
#include "plain.hpp"
#include "ros2.hpp"
#include "ros2PubSubTypes.h"
#include "saccade/cdr.hpp"
#include "saccade_plainPubSubTypes.h"
#include "saccade/schema.hpp"
#include "support.hpp"
#include "channel.hpp"
#include "wire.hpp"

namespace {

using namespace saccade;

// An ok Status passes; an error fails, showing its words.
::testing::AssertionResult is_ok(const Status& status) {
  if (status.ok()) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure() << status.message();
}

// The codec choose_codec picks; a failure (and nullptr) when it picks none.
const dds::Codec* chosen(std::string_view type, const dds::CodecRequest& request) {
  Result<const dds::Codec*> codec = dds::choose_codec(type, request);
  EXPECT_TRUE(codec.ok()) << type << ": " << codec.error();
  return codec.ok() ? *codec : nullptr;
}

// Through the type's TopicDataType, serialize then deserialize, as the bridges do.
template <class M>
void round_trip(const M& in, M& out) {
  const dds::Codec* codec = dds::find_codec(M::kTypeName);
  ASSERT_NE(codec, nullptr);
  auto type = codec->make_type();
  dds::CdrSample sample;
  sample.message = &in;
  eprosima::fastrtps::rtps::SerializedPayload_t payload(type->getSerializedSizeProvider(&sample)());
  ASSERT_TRUE(type->serialize(&sample, &payload));
  dds::CdrSample back;
  back.target = &out;
  ASSERT_TRUE(type->deserialize(&payload, &back));
  ASSERT_TRUE(is_ok(back.status));
}

void expect_same_stamp(const Message& a, const Message& b) {
  EXPECT_EQ(a.timestamp_ns, b.timestamp_ns);
  EXPECT_EQ(a.origin_ns, b.origin_ns);
  EXPECT_EQ(a.frame_id, b.frame_id);
}

void stamp(Message& m, int64_t k) {
  m.timestamp_ns = 1'700'000'000'123'456'789 + k;
  m.origin_ns = -42 - k;
  m.frame_id = 9'000'000'000 + k;
}

void expect_same_mat(const cv::Mat& a, const cv::Mat& b) {
  ASSERT_EQ(a.type(), b.type());
  ASSERT_EQ(a.size(), b.size());
  if (a.empty()) return;
  cv::Mat diff = a != b;
  if (diff.channels() > 1) diff = diff.reshape(1);
  EXPECT_EQ(cv::countNonZero(diff), 0);
}

Retina make_retina() {
  Retina r;
  stamp(r, 1);
  r.camera_id = 1;
  for (int l = 0; l < 5; ++l) {
    r.levels.push_back(test::random_image({32, 24}, l));
    r.geometry.push_back({cv::Rect(-10 * l, 3 * l, 32 << l, 24 << l), 1.0 * (1 << l), 1.5 * (1 << l)});
  }
  r.source_size = {1024, 768};
  r.fovea = {511, -3};
  r.sampling = Retina::Sampling::kAreaMean;
  return r;
}

void expect_same_retina(const Retina& a, const Retina& b) {
  expect_same_stamp(a, b);
  EXPECT_EQ(a.camera_id, b.camera_id);
  ASSERT_EQ(a.levels.size(), b.levels.size());
  for (std::size_t l = 0; l < a.levels.size(); ++l) {
    expect_same_mat(a.levels[l], b.levels[l]);
    EXPECT_EQ(a.geometry[l].region, b.geometry[l].region);
    EXPECT_EQ(a.geometry[l].step_x, b.geometry[l].step_x);
    EXPECT_EQ(a.geometry[l].step_y, b.geometry[l].step_y);
  }
  EXPECT_EQ(a.source_size, b.source_size);
  EXPECT_EQ(a.fovea, b.fovea);
  EXPECT_EQ(a.sampling, b.sampling);
}

TEST(DdsWire, ImagesOfAnyTypeAndLayoutRoundTripBitExactly) {
  std::vector<cv::Mat> mats = {test::random_image({1024, 768}, 1), test::random_image({640, 480}, 2, CV_8UC3),
                               cv::Mat(3, 5, CV_32FC1), cv::Mat(7, 2, CV_16SC2), cv::Mat()};
  cv::randu(mats[2], -1e6, 1e6);
  cv::randu(mats[3], -30000, 30000);
  // A view with padded rows travels as packed rows.
  mats.push_back(mats[1](cv::Rect(13, 17, 101, 55)));
  for (const auto& mat : mats) {
    Image in, out;
    stamp(in, 7);
    in.camera_id = 1;
    in.mat = mat;
    round_trip(in, out);
    expect_same_stamp(in, out);
    EXPECT_EQ(out.camera_id, 1);
    expect_same_mat(in.mat, out.mat);
  }
}

TEST(DdsWire, ARecycledImageKeepsItsBuffer) {
  Image in, out;
  in.mat = test::random_image({320, 240}, 3);
  round_trip(in, out);
  const uchar* buffer = out.mat.data;
  in.mat = test::random_image({320, 240}, 4);
  round_trip(in, out);
  EXPECT_EQ(out.mat.data, buffer);
  expect_same_mat(in.mat, out.mat);
}

TEST(DdsWire, RetinaKeepsLevelsAndGeometry) {
  Retina in = make_retina(), out;
  round_trip(in, out);
  expect_same_retina(in, out);
  EXPECT_EQ(out.source, nullptr);
}

TEST(DdsWire, FeatureMapsKeepNamesLevelsAndTheirRetina) {
  FeatureMaps in, out;
  stamp(in, 2);
  in.set_layout({"disparity", "confidence"}, 3);
  for (int f = 0; f < 2; ++f)
    for (int l = 0; l < 3; ++l) {
      in.maps[f][l].create(24, 32, CV_32F);
      cv::randu(in.maps[f][l], -5, 5);
    }
  in.retina = std::make_shared<Retina>(make_retina());
  round_trip(in, out);
  expect_same_stamp(in, out);
  EXPECT_EQ(in.names, out.names);
  ASSERT_EQ(out.maps.size(), 2u);
  for (int f = 0; f < 2; ++f)
    for (int l = 0; l < 3; ++l) expect_same_mat(in.maps[f][l], out.maps[f][l]);
  ASSERT_NE(out.retina, nullptr);
  expect_same_retina(*in.retina, *out.retina);
  in.retina.reset();
  round_trip(in, out);
  EXPECT_EQ(out.retina, nullptr);
}

// A reader refills the retina of an earlier message once no message holds it:
// no allocation per message in steady state, never a retina someone still reads.
TEST(DdsWire, AReaderReusesAReleasedRetinaAndNeverOneStillHeld) {
  FeatureMaps in;
  in.retina = std::make_shared<Retina>(make_retina());
  std::vector<uint8_t> bytes;
  cdr::write(in, cdr::Envelope{}, bytes);
  std::shared_ptr<Retina> spare;
  FeatureMaps first, second, third;
  cdr::Envelope envelope;
  auto read = [&](FeatureMaps& out) {
    ASSERT_TRUE(is_ok(cdr::read(bytes.data(), bytes.size(), out, envelope, &spare)));
  };
  read(first);
  ASSERT_NE(first.retina, nullptr);
  const Retina* held = first.retina.get();
  read(second);
  EXPECT_NE(second.retina.get(), held) << "the first message still holds its retina";
  expect_same_retina(*first.retina, *in.retina);
  const Retina* second_retina = second.retina.get();
  first.retina.reset();
  second.retina.reset();  // both released: the spare (the second) is free again
  read(third);
  EXPECT_EQ(third.retina.get(), second_retina);
  EXPECT_EQ(spare.get(), third.retina.get()) << "the reader keeps it for the next message";
  expect_same_retina(*third.retina, *in.retina);
}

TEST(DdsWire, MotionRegionAndGazeRequestRoundTrip) {
  Motion m, m2;
  stamp(m, 3);
  m.camera_id = 1;
  m.first = true;
  m.energy = {0.1, 2.5e-9, 3};
  m.moving = {0.5, 0, 1};
  m.centroid = {{1.25, -3}, {-1, -1}, {1e9, 7}};
  round_trip(m, m2);
  expect_same_stamp(m, m2);
  EXPECT_EQ(m.energy, m2.energy);
  EXPECT_EQ(m.moving, m2.moving);
  EXPECT_EQ(m.centroid, m2.centroid);
  EXPECT_EQ(m2.first, true);
  EXPECT_EQ(m2.camera_id, 1);

  Region r, r2;
  stamp(r, 4);
  r.center = {100.5, -0.25};
  r.size = {31, 24.5};
  r.score = 0.875;
  r.depth = 1.5;
  r.camera_id = 1;
  r.label = "visible";
  round_trip(r, r2);
  expect_same_stamp(r, r2);
  EXPECT_EQ(r.center, r2.center);
  EXPECT_EQ(r.size, r2.size);
  EXPECT_EQ(r.score, r2.score);
  EXPECT_EQ(r.depth, r2.depth);
  EXPECT_EQ(r.label, r2.label);

  GazeRequest g, g2;
  stamp(g, 5);
  g.kind = GazeRequest::Kind::kPixelDisparity;
  g.pixel = {600.25, 10};
  g.direction = {0.1, -0.2, 0.97};
  g.image_size = {1024, 768};
  g.focal_px = 887.5;
  g.depth = 2.25;
  g.disparity = 31.5;
  g.point = {1, 2, 3};
  g.azimuth = -0.3;
  g.elevation = 0.2;
  g.camera_id = 1;
  g.reason = "border";
  round_trip(g, g2);
  expect_same_stamp(g, g2);
  EXPECT_EQ(g2.kind, g.kind);
  EXPECT_EQ(g2.pixel, g.pixel);
  EXPECT_EQ(g2.direction, g.direction);
  EXPECT_EQ(g2.image_size, g.image_size);
  EXPECT_EQ(g2.focal_px, g.focal_px);
  EXPECT_EQ(g2.depth, g.depth);
  EXPECT_EQ(g2.disparity, g.disparity);
  EXPECT_EQ(g2.point, g.point);
  EXPECT_EQ(g2.azimuth, g.azimuth);
  EXPECT_EQ(g2.elevation, g.elevation);
  EXPECT_EQ(g2.camera_id, g.camera_id);
  EXPECT_EQ(g2.reason, g.reason);
}

TEST(DdsWire, JointStateAndTargetsRoundTrip) {
  JointState s, s2;
  stamp(s, 6);
  s.position = {0.1, -0.2, 0.3, -0.4, 1e-12};
  s.velocity = {1, 2, 3, 4, 5};
  s.health = {JointState::Health::kReady, JointState::Health::kFault, JointState::Health::kSilent,
              JointState::Health::kStarting, JointState::Health::kReady};
  s.updated_ns = {1, 2, 3, 4, INT64_MAX};
  s.error_code = {0, 0x8611, 0, 0, 0xFFFF};
  s.cycle = 123456789;
  s.detail = "joint 2: following error";
  round_trip(s, s2);
  expect_same_stamp(s, s2);
  EXPECT_EQ(s.position, s2.position);
  EXPECT_EQ(s.velocity, s2.velocity);
  EXPECT_EQ(s.health, s2.health);
  EXPECT_EQ(s.updated_ns, s2.updated_ns);
  EXPECT_EQ(s.error_code, s2.error_code);
  EXPECT_EQ(s.cycle, s2.cycle);
  EXPECT_EQ(s.detail, s2.detail);

  JointTargets t, t2;
  stamp(t, 7);
  t.position = {0.5, 0, -0.5, 0.25, 0};
  t.velocity = {0, 0.1, 0, 0, -0.1};
  t.hold = true;
  t.reset = 3;
  t.fault = "drive 4 silent";
  t.cause_origin_ns = 123456789;
  t.cause_taken_ns = 123999999;
  round_trip(t, t2);
  expect_same_stamp(t, t2);
  EXPECT_EQ(t.position, t2.position);
  EXPECT_EQ(t.velocity, t2.velocity);
  EXPECT_EQ(t.hold, t2.hold);
  EXPECT_EQ(t.reset, t2.reset);
  EXPECT_EQ(t.cause_origin_ns, t2.cause_origin_ns);
  EXPECT_EQ(t.cause_taken_ns, t2.cause_taken_ns);
  EXPECT_EQ(t.fault, t2.fault);
}

TEST(DdsWire, FoveaStateAndClassificationRoundTrip) {
  FoveaState f, f2;
  stamp(f, 8);
  f.state = FoveaState::State::kTracking;
  f.fovea = {1, 2};
  f.next = {3, 4};
  f.target = {5.5, 6.5, 20, 10};
  f.confidence = 12.5;
  f.target_valid = true;
  f.score = 0.93;
  f.attention_shift = true;
  f.gaze_request = true;
  f.attention_shifts = 11;
  f.gaze_requests = 12;
  f.frames_lost = 13;
  f.camera_id = 1;
  f.retina = std::make_shared<Retina>(make_retina());
  round_trip(f, f2);
  expect_same_stamp(f, f2);
  EXPECT_EQ(f2.state, f.state);
  EXPECT_EQ(f2.fovea, f.fovea);
  EXPECT_EQ(f2.next, f.next);
  EXPECT_EQ(f2.target, f.target);
  EXPECT_EQ(f2.target_valid, f.target_valid);
  EXPECT_EQ(f2.confidence, f.confidence);
  EXPECT_EQ(f2.score, f.score);
  EXPECT_EQ(f2.attention_shift, f.attention_shift);
  EXPECT_EQ(f2.gaze_request, f.gaze_request);
  EXPECT_EQ(f2.attention_shifts, f.attention_shifts);
  EXPECT_EQ(f2.gaze_requests, f.gaze_requests);
  EXPECT_EQ(f2.frames_lost, f.frames_lost);
  EXPECT_EQ(f2.camera_id, f.camera_id);
  ASSERT_NE(f2.retina, nullptr);
  expect_same_retina(*f.retina, *f2.retina);

  Classification c, c2;
  stamp(c, 9);
  c.outcome = Classification::Outcome::kProbable;
  c.best = 2;
  c.score = 0.61;
  c.scores = {0.1f, 0.2f, 0.61f};
  c.classes = std::make_shared<const std::vector<std::string>>(std::vector<std::string>{"zero", "one", "two"});
  c.roi = {10, 20, 30, 40};
  c.camera_id = 1;
  round_trip(c, c2);
  expect_same_stamp(c, c2);
  EXPECT_EQ(c2.outcome, c.outcome);
  EXPECT_EQ(c2.best, c.best);
  EXPECT_EQ(c2.score, c.score);
  EXPECT_EQ(c2.scores, c.scores);
  ASSERT_NE(c2.classes, nullptr);
  EXPECT_EQ(*c2.classes, *c.classes);
  EXPECT_EQ(c2.label(), "two");
  EXPECT_EQ(c2.roi, c.roi);
  // The names are shared again while they do not change.
  auto names = c2.classes;
  round_trip(c, c2);
  EXPECT_EQ(c2.classes, names);
}

TEST(DdsWire, CanFramesRoundTripWithIdsFlagsAndBytes) {
  CanFrames in, out;
  stamp(in, 3);
  in.bus = "socketcan:can0";
  CanFrames::Frame a;
  a.can_id = 0x1ABCDEF | CanFrames::kExtended;
  a.length = 5;
  a.data = {9, 8, 7, 6, 5};
  a.timestamp_ns = 123456789;
  CanFrames::Frame fd;
  fd.can_id = 0x181;
  fd.flags = CanFrames::kFd | CanFrames::kErrorStateIndicator;
  fd.length = 64;
  for (int i = 0; i < 64; ++i) fd.data[static_cast<std::size_t>(i)] = static_cast<uint8_t>(255 - i);
  in.frames = {a, fd, CanFrames::Frame{}};
  round_trip(in, out);
  expect_same_stamp(in, out);
  EXPECT_EQ(out.bus, in.bus);
  EXPECT_EQ(out.frames, in.frames);
}

template <class M>
void expect_every_field_round_trips() {
  M in, out;
  stamp(in, 7);
  test::fill_every_field(in);
  round_trip(in, out);
  std::string a, b;
  append_json(a, in);
  append_json(b, out);
  EXPECT_EQ(a, b) << M::kTypeName;
}

// Every type schema.hpp lists (the one list the JSON writer and the schemas
// walk too); returns how many.
template <class... M>
std::size_t every_field_round_trips(saccade::TypeList<M...>) {
  (expect_every_field_round_trips<M>(), ...);
  return sizeof...(M);
}

// Each type's fields as it describes them (message.hpp's `fields`) all survive
// its wire form (which is derived from the same description: this guards the
// CDR writer and reader's overloads, one per kind of field).
TEST(DdsWire, EveryDescribedFieldOfEveryTypeSurvivesTheWire) {
  EXPECT_EQ(every_field_round_trips(saccade::MessageTypes{}), described_message_types().size());
  EXPECT_EQ(described_message_types().size(), 13u);
}

TEST(DdsWire, EveryMessageTypeHasACodec) {
  for (auto type : {"Image", "Retina", "FeatureMaps", "Motion", "Region", "StereoFixation", "GazeRequest", "JointState",
                    "JointTargets", "HeadPose", "FoveaState", "Classification", "CanFrames"}) {
    const dds::Codec* codec = dds::find_codec(type);
    ASSERT_NE(codec, nullptr) << type;
    EXPECT_EQ(codec->type, type);
    EXPECT_EQ(codec->capacity, 0u) << "the serialised form";
    EXPECT_NE(codec->make_sample({}), nullptr);
    EXPECT_NE(codec->make_type(), nullptr);
  }
  EXPECT_EQ(dds::find_codec("NoSuchType"), nullptr);
}

// --- The plain (shared-memory) forms. Their samples are megabytes: on the heap.

TEST(DdsPlain, ImagesRoundTripBitExactlyWhateverTheirLayout) {
  auto sample = std::make_unique<saccade_plain::Image4M>();
  cv::Mat big = test::random_image({1280, 720}, 3, CV_8UC3);
  std::vector<cv::Mat> mats = {test::random_image({1024, 768}, 1), test::random_image({1024, 768}, 2, CV_8UC3),
                               cv::Mat(3, 5, CV_32FC1), big(cv::Rect(7, 5, 301, 199)), cv::Mat()};
  cv::randu(mats[2], -1e6, 1e6);
  Image back;
  for (std::size_t i = 0; i < mats.size(); ++i) {
    Image image;
    stamp(image, static_cast<int64_t>(i));
    image.camera_id = static_cast<int>(i);
    image.mat = mats[i];
    ASSERT_TRUE(is_ok(dds::to_plain(image, *sample))) << i;
    EXPECT_EQ(sample->size(), mats[i].total() * mats[i].elemSize()) << "only the used bytes count";
    ASSERT_TRUE(is_ok(dds::from_plain(*sample, back))) << i;
    expect_same_stamp(image, back);
    EXPECT_EQ(back.camera_id, image.camera_id);
    expect_same_mat(image.mat, back.mat);
    EXPECT_TRUE(back.mat.empty() || back.mat.isContinuous());
  }
}

TEST(DdsPlain, TheReaderReusesItsBufferForFramesOfOneSize) {
  auto sample = std::make_unique<saccade_plain::Image1M>();
  Image image, back;
  image.mat = test::random_image({640, 480}, 1);
  ASSERT_TRUE(is_ok(dds::to_plain(image, *sample)));
  ASSERT_TRUE(is_ok(dds::from_plain(*sample, back)));
  const uint8_t* buffer = back.mat.data;
  image.mat = test::random_image({640, 480}, 2);
  ASSERT_TRUE(is_ok(dds::to_plain(image, *sample)));
  ASSERT_TRUE(is_ok(dds::from_plain(*sample, back)));
  EXPECT_EQ(back.mat.data, buffer);
  expect_same_mat(image.mat, back.mat);
}

TEST(DdsPlain, AnImageLargerThanTheCapacityIsRefusedWithTheFix) {
  auto sample = std::make_unique<saccade_plain::Image1M>();
  Image image;
  image.mat = test::random_image({1024, 768}, 1, CV_8UC3);
  EXPECT_EQ(dds::to_plain(image, *sample).message(),
            "a 1024x768 image of 2359296 bytes does not fit the edge's shared-memory capacity (1 MiB); give the edge a "
            "larger one (qos=\"capacity=16M\")");
}

TEST(DdsPlain, MalformedHeadersGiveEmptyMatsNotCrashes) {
  auto sample = std::make_unique<saccade_plain::Image1M>();
  Image image, back;
  image.mat = test::random_image({64, 48}, 1);
  ASSERT_TRUE(is_ok(dds::to_plain(image, *sample)));
  sample->mat().rows(100000);  // points past the used bytes
  EXPECT_EQ(dds::from_plain(*sample, back).message(),
            "an image of 6400000 bytes at byte 0 of a sample that holds 3072");
  EXPECT_TRUE(back.mat.empty());
  sample->mat().rows(48);
  sample->mat().cv_type(12345);  // no OpenCV type
  EXPECT_EQ(dds::from_plain(*sample, back).message(), "a malformed image header (48x64, type 12345)");
  EXPECT_TRUE(back.mat.empty());
  sample->mat().cv_type(CV_8UC1);
  sample->size(1 << 30);  // a size beyond the array is clamped to it
  EXPECT_TRUE(is_ok(dds::from_plain(*sample, back)));
  expect_same_mat(image.mat, back.mat);
}

TEST(DdsPlain, RetinasRoundTripBitExactly) {
  auto sample = std::make_unique<saccade_plain::Retina1M>();
  Retina r = make_retina();
  r.levels[2] = test::random_image({32, 24}, 7, CV_32FC1);
  ASSERT_TRUE(is_ok(dds::to_plain(r, *sample)));
  Retina back;
  ASSERT_TRUE(is_ok(dds::from_plain(*sample, back)));
  expect_same_retina(r, back);
  sample->level_count(17);
  EXPECT_EQ(dds::from_plain(*sample, back).message(), "a retina of 17 levels (at most 16)");
  r.levels.resize(17);
  r.geometry.resize(17);
  EXPECT_THAT(dds::to_plain(r, *sample).message(), ::testing::HasSubstr("at most 16 levels"));
}

TEST(DdsPlain, TheSmallestPlainFormAtLeastTheCapacityIsChosen) {
  EXPECT_EQ(dds::find_plain_codec("Image", 0)->capacity, 4u << 20) << "the default";
  EXPECT_EQ(dds::find_plain_codec("Image", 1000)->capacity, 1u << 20);
  EXPECT_EQ(dds::find_plain_codec("Image", (1u << 20) + 1)->capacity, 4u << 20);
  EXPECT_EQ(dds::find_plain_codec("Image", 6'220'800)->capacity, 16u << 20) << "1920x1080 colour";
  EXPECT_EQ(dds::find_plain_codec("Image", (16u << 20) + 1), nullptr);
  EXPECT_EQ(dds::find_plain_codec("Retina", 0)->capacity, 1u << 20);
  EXPECT_EQ(dds::find_plain_codec("JointState", 0), nullptr) << "small types stay serialised";
  for (const auto& c : dds::plain_codecs()) EXPECT_TRUE(c.make_type()->is_plain()) << c.type << " " << c.capacity;
}

// A loaned sample is the C++ struct written straight into Fast DDS' payload,
// which holds the type's CDR size: a struct that C++ pads beyond it spills
// into the next payload (ImageRef once did, by the 8 bytes of its post).
template <class Sample, class PubSub>
void expect_it_fits_its_loan(const char* name) {
  PubSub type;
  EXPECT_TRUE(type.is_plain()) << name;
  EXPECT_LE(sizeof(Sample), Sample::getMaxCdrSerializedSize()) << name;
  EXPECT_LE(sizeof(Sample) + 4, type.m_typeSize) << name << ": the loan (its CDR size and encapsulation)";
}

TEST(DdsPlain, EveryPlainSampleFitsTheLoanFastDdsGivesIt) {
  namespace p = saccade_plain;
  expect_it_fits_its_loan<p::ImageRef, p::ImageRefPubSubType>("ImageRef");
  expect_it_fits_its_loan<p::RetinaRef, p::RetinaRefPubSubType>("RetinaRef");
  expect_it_fits_its_loan<p::Image1M, p::Image1MPubSubType>("Image1M");
  expect_it_fits_its_loan<p::Image4M, p::Image4MPubSubType>("Image4M");
  expect_it_fits_its_loan<p::Image16M, p::Image16MPubSubType>("Image16M");
  expect_it_fits_its_loan<p::Retina1M, p::Retina1MPubSubType>("Retina1M");
}

// --- The frame-ring forms: the sample says where the pixels are; the reader views them in place.

std::shared_ptr<dds::FrameRing> ring_of(std::size_t bytes, uint32_t slots = 4) {
  auto ring = dds::FrameRing::create(bytes, slots);
  EXPECT_TRUE(is_ok(ring.status()));
  return ring.ok() ? *ring : nullptr;
}

TEST(DdsRing, ImagesRoundTripBitExactlyWhateverTheirLayout) {
  auto ring = ring_of(4u << 20);
  ASSERT_TRUE(ring);
  saccade_plain::ImageRef sample;
  dds::RingReader reader;
  cv::Mat big = test::random_image({1280, 720}, 3, CV_8UC3);
  std::vector<cv::Mat> mats = {test::random_image({1024, 768}, 1), test::random_image({1024, 768}, 2, CV_8UC3),
                               cv::Mat(3, 5, CV_32FC1), big(cv::Rect(7, 5, 301, 199)), cv::Mat()};
  cv::randu(mats[2], -1e6, 1e6);
  for (std::size_t i = 0; i < mats.size(); ++i) {
    Image image, back;
    stamp(image, static_cast<int64_t>(i));
    image.camera_id = static_cast<int>(i);
    image.mat = mats[i];
    cv::Mat hold;
    ASSERT_TRUE(is_ok(dds::to_ring(image, *ring, hold, sample))) << i;
    ASSERT_TRUE(is_ok(dds::from_ring(sample, reader, back))) << i;
    expect_same_stamp(image, back);
    EXPECT_EQ(back.camera_id, image.camera_id);
    expect_same_mat(image.mat, back.mat);
    EXPECT_TRUE(back.mat.empty() || back.mat.isContinuous());
  }
  EXPECT_EQ(reader.copied(), 0u) << "all read in place";
}

TEST(DdsRing, AnImageAProducerWroteIntoTheRingIsNotCopiedAgain) {
  auto ring = ring_of(1u << 20);
  ASSERT_TRUE(ring);
  Image image;
  image.mat.allocator = ring.get();
  image.mat.create(480, 640, CV_8UC1);
  test::random_image({640, 480}, 5).copyTo(image.mat);
  saccade_plain::ImageRef sample;
  cv::Mat hold;
  ASSERT_TRUE(is_ok(dds::to_ring(image, *ring, hold, sample)));
  EXPECT_TRUE(hold.empty()) << "no buffer taken for a copy";
  EXPECT_EQ(ring->held_slots(), 1u);
  dds::RingAddress at;
  std::size_t offset = 0;
  ASSERT_TRUE(ring->locate(image.mat, at, offset));
  EXPECT_EQ(sample.ring().slot(), at.slot);
  EXPECT_EQ(sample.ring().generation(), at.generation);

  dds::RingReader reader;
  Image back;
  ASSERT_TRUE(is_ok(dds::from_ring(sample, reader, back)));
  expect_same_mat(image.mat, back.mat);
}

TEST(DdsRing, RetinasTravelInOneBufferAndRoundTripBitExactly) {
  auto ring = ring_of(1u << 20);
  ASSERT_TRUE(ring);
  Retina r = make_retina();
  r.levels[2] = test::random_image({32, 24}, 7, CV_32FC1);
  saccade_plain::RetinaRef sample;
  cv::Mat hold;
  ASSERT_TRUE(is_ok(dds::to_ring(r, *ring, hold, sample)));
  EXPECT_FALSE(hold.empty());
  dds::RingReader reader;
  Retina back;
  ASSERT_TRUE(is_ok(dds::from_ring(sample, reader, back)));
  expect_same_retina(r, back);
  hold.release();
  EXPECT_EQ(ring->held_slots(), 1u) << "all five levels pin one buffer";
  back.levels.clear();
  EXPECT_EQ(ring->held_slots(), 0u);
  r.levels.resize(17);
  r.geometry.resize(17);
  EXPECT_THAT(dds::to_ring(r, *ring, hold, sample).message(), ::testing::HasSubstr("at most 16 levels"));
}

TEST(DdsRing, ARetinaWhoseLevelsWereMadeTogetherInTheRingIsNotCopiedAgain) {
  auto ring = ring_of(1u << 20);
  ASSERT_TRUE(ring);
  Retina r = make_retina();
  std::vector<cv::Mat> in_ring;
  create_together(ring.get(), r.levels.size(), r.levels[0].size(), r.levels[0].type(), in_ring);
  for (std::size_t k = 0; k < r.levels.size(); ++k) r.levels[k].copyTo(in_ring[k]);
  Retina made = r;
  made.levels = in_ring;
  saccade_plain::RetinaRef sample;
  cv::Mat hold;
  ASSERT_TRUE(is_ok(dds::to_ring(made, *ring, hold, sample)));
  EXPECT_TRUE(hold.empty()) << "no buffer taken for a copy";
  dds::RingReader reader;
  Retina back;
  ASSERT_TRUE(is_ok(dds::from_ring(sample, reader, back)));
  expect_same_retina(r, back);
}

TEST(DdsRing, AFrameLargerThanABufferIsRefusedWithTheFixAndAFullRingIsAFailedWrite) {
  auto ring = ring_of(1u << 20, 4);
  ASSERT_TRUE(ring);
  Image image;
  image.mat = test::random_image({1024, 768}, 1, CV_8UC3);
  saccade_plain::ImageRef sample;
  cv::Mat hold;
  const Status too_large = dds::to_ring(image, *ring, hold, sample);
  EXPECT_FALSE(dds::is_ring_full(too_large));
  EXPECT_EQ(too_large.message(),
            "a frame of 2359296 bytes does not fit the edge's frame ring (buffers of 1 MiB); give the edge a larger "
            "one (qos=\"capacity=16M\")");
  std::vector<cv::Mat> held;
  for (int i = 0; i < 4; ++i) held.push_back(ring->take(10));
  image.mat = test::random_image({64, 48}, 1);
  const Status full = dds::to_ring(image, *ring, hold, sample);
  EXPECT_TRUE(dds::is_ring_full(full)) << full.message();
  EXPECT_EQ(full.message(), dds::kRingFull);
}

TEST(DdsRing, MalformedHeadersAreRefusedNotCrashes) {
  auto ring = ring_of(1u << 20);
  ASSERT_TRUE(ring);
  Image image, back;
  image.mat = test::random_image({64, 48}, 1);
  saccade_plain::ImageRef sample;
  cv::Mat hold;
  ASSERT_TRUE(is_ok(dds::to_ring(image, *ring, hold, sample)));
  dds::RingReader reader;
  sample.mat().rows(100000);  // past the buffer's end
  const Status outside = dds::from_ring(sample, reader, back);
  EXPECT_THAT(outside.message(), ::testing::HasSubstr("outside the writer's ring"));
  sample.mat().rows(48);
  sample.mat().cv_type(12345);
  const Status malformed = dds::from_ring(sample, reader, back);
  EXPECT_THAT(malformed.message(), ::testing::HasSubstr("malformed"));
  sample.mat().cv_type(CV_8UC1);
  sample.mat().rows(-1);
  EXPECT_FALSE(dds::from_ring(sample, reader, back).ok());
  sample.mat().rows(48);
  ASSERT_TRUE(is_ok(dds::from_ring(sample, reader, back)));
  expect_same_mat(image.mat, back.mat);
}

TEST(DdsRing, ZeroCopyPicksTheRingForImagesTheMailboxForOtherTypesOrWhatIsAsked) {
  using SharedMemory = dds::CodecRequest::SharedMemory;
  EXPECT_EQ(chosen("Image", {.zero_copy = true})->form, dds::Codec::Form::kRing);
  // The mailbox carries the serialised form.
  EXPECT_EQ(chosen("Retina", {.zero_copy = true})->form, dds::Codec::Form::kSerialized);
  EXPECT_EQ(chosen("Image", {.zero_copy = true, .shared_memory = SharedMemory::kMailbox})->form,
            dds::Codec::Form::kSerialized);
  // A reliable image edge is not promised every frame by a ring of reused buffers: loans.
  for (SharedMemory asked : {SharedMemory::kAuto, SharedMemory::kRing})
    EXPECT_EQ(chosen("Image", {.zero_copy = true, .shared_memory = asked, .reliable = true})->form,
              dds::Codec::Form::kPlain);
  for (const char* type : {"Image", "Retina"}) {
    const dds::Codec* ring = chosen(type, {.zero_copy = true, .shared_memory = SharedMemory::kRing});
    ASSERT_NE(ring, nullptr);
    EXPECT_EQ(ring->form, dds::Codec::Form::kRing) << type;
    EXPECT_TRUE(ring->make_type()->is_plain()) << type << ": data sharing for the small sample too";
    const dds::Codec* loans = chosen(type, {.zero_copy = true, .shared_memory = SharedMemory::kLoans});
    ASSERT_NE(loans, nullptr);
    EXPECT_EQ(loans->form, dds::Codec::Form::kPlain) << type;
  }
  EXPECT_EQ(chosen("JointState", {.zero_copy = true})->form, dds::Codec::Form::kSerialized);
}

TEST(DdsMailbox, OnlyZeroCopySerialisedEdgesThatDoNotAskForLoansUseTheMailbox) {
  using SharedMemory = dds::CodecRequest::SharedMemory;
  auto uses = [&](const char* type, dds::CodecRequest request) {
    Result<const dds::Codec*> codec = dds::choose_codec(type, request);
    dds::WireOptions options;
    if (codec.ok()) dds::set_mailbox(request, **codec, 8, options);
    return codec.ok() && options.mailbox;
  };
  EXPECT_TRUE(uses("JointTargets", {.zero_copy = true, .reliable = true}));
  EXPECT_TRUE(uses("Retina", {.zero_copy = true}));
  EXPECT_TRUE(uses("Image", {.zero_copy = true, .shared_memory = SharedMemory::kMailbox}));
  EXPECT_FALSE(uses("JointTargets", {})) << "not zero copy: another host may read it";
  EXPECT_FALSE(uses("Image", {.zero_copy = true})) << "the frame ring has its own mailbox";
  // What the bridges ask for under DDS security: the mailbox would bypass it.
  EXPECT_FALSE(uses("JointTargets", {.zero_copy = true, .shared_memory = SharedMemory::kLoans}));
  EXPECT_FALSE(uses("Retina", {.zero_copy = true, .shared_memory = SharedMemory::kLoans}));
  EXPECT_FALSE(uses("JointState", {.zero_copy = true, .ros2 = true})) << "ROS 2's type";
}

// A buffer one byte short gets nothing past its end and a 0; an exact one the whole message.
TEST(DdsWire, AMessageIsWrittenOnlyIntoABufferWithRoomForIt) {
  Region r;
  r.label = "a label";
  const std::size_t n = cdr::size_of(r);
  std::vector<uint8_t> buffer(n + 1, 0xAB);
  EXPECT_EQ(cdr::write(r, cdr::Envelope{}, buffer.data(), n - 1), 0u);
  EXPECT_EQ(buffer[n - 1], 0xAB) << "nothing written past the capacity";
  EXPECT_EQ(cdr::write(r, cdr::Envelope{}, buffer.data(), n), n);
  EXPECT_EQ(buffer[n], 0xAB);
  Region out;
  cdr::Envelope envelope;
  ASSERT_TRUE(cdr::read(buffer.data(), n, out, envelope).ok());
  EXPECT_EQ(out.label, r.label);
}

// An enum value the type does not name is no message (the reader counts it
// as unreadable), not a guess at what the writer meant.
TEST(DdsWire, AnOutOfRangeEnumMakesTheSampleUnreadable) {
  JointState s;
  s.health = {JointState::Health::kStarting, JointState::Health::kReady, static_cast<JointState::Health>(200)};
  std::vector<uint8_t> bytes;
  cdr::write(s, cdr::Envelope{}, bytes);
  JointState out;
  cdr::Envelope envelope;
  const Status unnamed = cdr::read(bytes.data(), bytes.size(), out, envelope);
  EXPECT_THAT(unnamed.message(), ::testing::HasSubstr("health: 200 is not a value it names"));
  s.health.back() = JointState::Health::kSilent;
  cdr::write(s, cdr::Envelope{}, bytes);
  EXPECT_TRUE(is_ok(cdr::read(bytes.data(), bytes.size(), out, envelope)));
  EXPECT_EQ(out.health, s.health);
}

// --- ROS 2 forms ---

namespace ros = sensor_msgs::msg::dds_;

// CDR bytes of `wire` through its generated type, and back.
template <class W, class P>
W cdr_round_trip(const W& wire, std::vector<uint8_t>* bytes = nullptr) {
  P type;
  eprosima::fastrtps::rtps::SerializedPayload_t payload(type.getSerializedSizeProvider(const_cast<W*>(&wire))());
  EXPECT_TRUE(type.serialize(const_cast<W*>(&wire), &payload));
  if (bytes) bytes->assign(payload.data, payload.data + payload.length);
  W back;
  EXPECT_TRUE(type.deserialize(&payload, &back));
  return back;
}

TEST(DdsRos2, TheTypesCarryRos2sNames) {
  EXPECT_EQ(ros::Image_PubSubType().getName(), std::string("sensor_msgs::msg::dds_::Image_"));
  EXPECT_EQ(ros::JointState_PubSubType().getName(), std::string("sensor_msgs::msg::dds_::JointState_"));
  EXPECT_EQ(dds::ros2_topic("camera/image_raw"), "rt/camera/image_raw");
  EXPECT_EQ(dds::ros2_topic("/joint_states"), "rt/joint_states");
}

// The CDR bytes ROS 2 puts on the wire for sensor_msgs/Image, written out by
// hand from the message definition: any layout difference fails here.
TEST(DdsRos2, AnImageIsTheCdrBytesRos2Expects) {
  Image in;
  in.timestamp_ns = 1'000'000'002;  // 1 s 2 ns
  in.mat = (cv::Mat_<uint8_t>(1, 2) << 7, 9);
  ros::Image_ wire;
  dds::to_ros2(in, {.frame_id = "ab", .joint_names = {}}, wire);
  std::vector<uint8_t> bytes;
  cdr_round_trip<ros::Image_, ros::Image_PubSubType>(wire, &bytes);
  const int pad = -1;                                                           // alignment padding: any value
  const std::vector<int> expected = {0, 1,   0, 0,                              // encapsulation: CDR little endian
                                     1, 0,   0, 0, 2,   0,   0,   0,            // header.stamp.sec, nanosec
                                     3, 0,   0, 0, 'a', 'b', 0,   pad,          // header.frame_id
                                     1, 0,   0, 0, 2,   0,   0,   0,            // height, width
                                     6, 0,   0, 0, 'm', 'o', 'n', 'o', '8', 0,  // encoding
                                     0, pad,                                    // is_bigendian
                                     2, 0,   0, 0,                              // step
                                     2, 0,   0, 0, 7,   9};                     // data
  ASSERT_EQ(bytes.size(), expected.size());
  for (std::size_t i = 0; i < bytes.size(); ++i)
    if (expected[i] != pad) { EXPECT_EQ(bytes[i], expected[i]) << "byte " << i; }
}

TEST(DdsRos2, ImagesKeepPixelsStampAndCameraInEveryEncoding) {
  struct Case {
    cv::Mat mat;
    const char* encoding;
  };
  cv::Mat f(3, 5, CV_32FC1), s(4, 3, CV_16SC2);
  cv::randu(f, -1e6, 1e6);
  cv::randu(s, -30000, 30000);
  const cv::Mat color = test::random_image({64, 48}, 2, CV_8UC3);
  cv::Mat wide(6, 7, CV_16UC1);
  cv::randu(wide, 0, 65535);
  std::vector<Case> cases = {
      {test::random_image({32, 24}, 1), "mono8"}, {color, "bgr8"}, {wide, "mono16"}, {f, "32FC1"}, {s, "16SC2"},
      {color(cv::Rect(3, 5, 17, 11)), "bgr8"}};
  for (const auto& c : cases) {
    Image in, out;
    in.timestamp_ns = 1'700'000'000'123'456'789;
    in.camera_id = 1;
    in.mat = c.mat;
    ros::Image_ wire;
    dds::to_ros2(in, {}, wire);
    EXPECT_EQ(wire.encoding(), c.encoding);
    EXPECT_EQ(wire.header().frame_id(), "camera_1");
    EXPECT_EQ(wire.header().stamp().sec(), 1'700'000'000);
    EXPECT_EQ(wire.header().stamp().nanosec(), 123'456'789u);
    EXPECT_EQ(wire.step(), c.mat.cols * c.mat.elemSize());
    ASSERT_TRUE(is_ok(dds::from_ros2(cdr_round_trip<ros::Image_, ros::Image_PubSubType>(wire), out)));
    EXPECT_EQ(out.timestamp_ns, in.timestamp_ns);
    EXPECT_EQ(out.camera_id, 1);
    expect_same_mat(in.mat, out.mat);
  }
}

// What ROS 2 cameras publish and saccade does not: RGB order, padded rows, big endian.
TEST(DdsRos2, RgbPaddedAndBigEndianImagesAreReadAsSaccadeImages) {
  const cv::Mat bgr = test::random_image({9, 4}, 5, CV_8UC3);
  cv::Mat rgb;
  cv::cvtColor(bgr, rgb, cv::COLOR_BGR2RGB);
  ros::Image_ wire;
  wire.height(4);
  wire.width(9);
  wire.encoding("rgb8");
  wire.step(32);  // 27 bytes of pixels, 5 of padding
  wire.data().assign(32 * 4, 0xEE);
  for (int r = 0; r < 4; ++r) std::memcpy(wire.data().data() + 32 * r, rgb.ptr(r), 27);
  wire.header().frame_id("left_optical_frame");
  Image out;
  ASSERT_TRUE(is_ok(dds::from_ros2(wire, out)));
  expect_same_mat(bgr, out.mat);
  EXPECT_EQ(out.camera_id, 0) << "a frame name that is not camera_<n>";

  ros::Image_ big;
  big.height(1);
  big.width(2);
  big.encoding("mono16");
  big.is_bigendian(1);
  big.step(4);
  big.data() = {0x12, 0x34, 0xAB, 0xCD};
  ASSERT_TRUE(is_ok(dds::from_ros2(big, out)));
  EXPECT_EQ(out.mat.at<uint16_t>(0, 0), 0x1234);
  EXPECT_EQ(out.mat.at<uint16_t>(0, 1), 0xABCD);
}

TEST(DdsRos2, UnreadableImagesSayWhy) {
  ros::Image_ wire;
  wire.height(2);
  wire.width(3);
  wire.encoding("bayer_rggb8");
  wire.step(3);
  wire.data().resize(6);
  Image out;
  const Status bayer = dds::from_ros2(wire, out);
  EXPECT_THAT(bayer.message(), ::testing::HasSubstr("image encoding 'bayer_rggb8' is not one saccade reads"));
  wire.encoding("mono8");
  wire.data().resize(5);
  EXPECT_EQ(dds::from_ros2(wire, out).message(), "a 3x2 mono8 image with step 3 needs 6 bytes of data, it has 5");
  wire.data().resize(6);
  wire.step(2);
  EXPECT_FALSE(dds::from_ros2(wire, out).ok()) << "a step shorter than a row";
}

TEST(DdsRos2, JointStatesTravelByName) {
  const dds::WireOptions options{.frame_id = "", .joint_names = {"neck", "vergence_left", "tilt_left"}};
  JointState in;
  in.timestamp_ns = 5'000'000'123;
  in.position = {0.1, -0.2, 0.3};
  in.velocity = {1, 2, 3};
  ros::JointState_ wire;
  dds::to_ros2(in, options, wire);
  EXPECT_EQ(wire.name(), (std::vector<std::string>{"neck", "vergence_left", "tilt_left"}));
  EXPECT_TRUE(wire.effort().empty());
  JointState out;
  ASSERT_TRUE(is_ok(dds::from_ros2(cdr_round_trip<ros::JointState_, ros::JointState_PubSubType>(wire), options, out)));
  EXPECT_EQ(out.timestamp_ns, in.timestamp_ns);
  EXPECT_EQ(out.position, in.position);
  EXPECT_EQ(out.velocity, in.velocity);
  EXPECT_TRUE(out.all_ready());

  // Another publisher's order, one joint missing, one saccade does not know.
  ros::JointState_ other;
  other.name() = {"tilt_left", "gripper", "neck"};
  other.position() = {3, 99, 1};
  ASSERT_TRUE(is_ok(dds::from_ros2(other, options, out)));
  ASSERT_EQ(out.position.size(), 3u);
  EXPECT_EQ(out.position[0], 1);
  EXPECT_TRUE(std::isnan(out.position[1]));
  EXPECT_EQ(out.position[2], 3);
  EXPECT_EQ(out.health[1], JointState::Health::kSilent);
  EXPECT_EQ(out.detail, "joint vergence_left is not in the message");
  EXPECT_EQ(out.velocity, (std::vector<double>{0, 0, 0})) << "no velocities in the message";

  other.velocity() = {1, 2};
  EXPECT_EQ(dds::from_ros2(other, options, out).message(), "a joint state with 3 names, 3 positions and 2 velocities");
}

TEST(DdsRos2, OnlyTypesRos2HasCanBeRos2Topics) {
  const dds::Codec* image = chosen("Image", {.zero_copy = true, .capacity = 0, .ros2 = true});
  ASSERT_NE(image, nullptr);
  EXPECT_EQ(image->form, dds::Codec::Form::kRos2) << "ROS 2 wins over zero copy: ROS 2 cannot read plain types";
  EXPECT_EQ(std::string(image->make_type()->getName()), "sensor_msgs::msg::dds_::Image_");
  EXPECT_EQ(chosen("JointState", {.ros2 = true})->form, dds::Codec::Form::kRos2);
  Result<const dds::Codec*> retina = dds::choose_codec("Retina", {.ros2 = true});
  EXPECT_FALSE(retina.ok());
  EXPECT_EQ(retina.error(), "ROS 2 has no message for Retina (it has for Image, JointState)");
}

}  // namespace

namespace saccade {
namespace {

// A message as a log or a live view carries it (channel.hpp): every described
// field of every type survives its channel's bytes.
template <class M>
void expect_channel_round_trip() {
  M in;
  in.timestamp_ns = 123456789;
  in.origin_ns = 42;
  in.frame_id = 7;
  test::fill_every_field(in);
  const dds::ChannelEncoding* e = dds::channel_encoding(M::kTypeName, false);
  ASSERT_NE(e, nullptr) << M::kTypeName;
  EXPECT_EQ(e->schema_encoding, "omgidl");
  EXPECT_EQ(e->schema_name, "saccade_idl::" + std::string(M::kTypeName));
  EXPECT_THAT(e->schema, ::testing::HasSubstr("struct " + std::string(M::kTypeName) + " {")) << M::kTypeName;
  auto encoder = dds::make_encoder(*e);
  auto decoder = dds::make_decoder(*e);
  ASSERT_TRUE(encoder && decoder);
  std::vector<uint8_t> bytes;
  ASSERT_TRUE(is_ok(encoder->encode(in, bytes)));
  Result<MessagePtr> out = decoder->decode(bytes.data(), bytes.size());
  ASSERT_TRUE(is_ok(out.status()));
  std::string a, b;
  append_json(a, in);
  append_json(b, **out);
  EXPECT_EQ(a, b) << M::kTypeName;
  // JSON gives a matrix by its shape: the message encoded again is the same
  // bytes, its pixels too.
  std::vector<uint8_t> again;
  ASSERT_TRUE(is_ok(encoder->encode(**out, again)));
  EXPECT_TRUE(again == bytes) << M::kTypeName << ": encoded again, " << again.size() << " bytes against "
                              << bytes.size();
  // Truncated bytes are an error, not a crash.
  Result<MessagePtr> truncated = decoder->decode(bytes.data(), bytes.size() / 2);
  EXPECT_FALSE(truncated.ok());
  EXPECT_FALSE(truncated.error().empty());
}

TEST(Channel, EveryDescribedFieldOfEveryTypeSurvivesItsChannel) {
  expect_channel_round_trip<Image>();
  expect_channel_round_trip<Retina>();
  expect_channel_round_trip<FeatureMaps>();
  expect_channel_round_trip<Motion>();
  expect_channel_round_trip<Region>();
  expect_channel_round_trip<StereoFixation>();
  expect_channel_round_trip<GazeRequest>();
  expect_channel_round_trip<JointState>();
  expect_channel_round_trip<JointTargets>();
  expect_channel_round_trip<HeadPose>();
  expect_channel_round_trip<FoveaState>();
  expect_channel_round_trip<Classification>();
  expect_channel_round_trip<CanFrames>();
  EXPECT_EQ(dds::channel_types().size(), described_message_types().size());
  EXPECT_EQ(dds::channel_encoding("NoSuchType", true), nullptr);
  EXPECT_EQ(dds::written_encoding("NoSuchType"), nullptr);
}

TEST(Channel, ImagesAndJointStatesTravelAsRos2Messages) {
  const dds::ChannelEncoding* e = dds::channel_encoding("Image", true);
  ASSERT_NE(e, nullptr);
  EXPECT_EQ(e->schema_name, "sensor_msgs/msg/Image");
  EXPECT_EQ(e->schema_encoding, "ros2msg");
  EXPECT_EQ(e->schema.rfind("std_msgs/Header header\n", 0), 0u);
  EXPECT_THAT(e->schema, ::testing::HasSubstr("MSG: builtin_interfaces/Time"));
  Image in;
  in.mat = test::random_image({64, 48}, 3, CV_8UC3);
  in.timestamp_ns = 1'500'000'001;
  std::vector<uint8_t> bytes;
  ASSERT_TRUE(is_ok(dds::make_encoder(*e)->encode(in, bytes)));
  // The CDR a ROS 2 node writes: encapsulation, then the header's stamp.
  ASSERT_GT(bytes.size(), 12u);
  EXPECT_EQ(bytes[1], 1) << "CDR little endian";
  int32_t sec = 0;
  std::memcpy(&sec, bytes.data() + 4, 4);
  EXPECT_EQ(sec, 1);
  Result<MessagePtr> decoded = dds::make_decoder(*e)->decode(bytes.data(), bytes.size());
  ASSERT_TRUE(is_ok(decoded.status()));
  auto out = std::dynamic_pointer_cast<const Image>(*decoded);
  ASSERT_NE(out, nullptr);
  EXPECT_EQ(cv::norm(out->mat, in.mat, cv::NORM_INF), 0.0);
  EXPECT_EQ(out->timestamp_ns, in.timestamp_ns);
  EXPECT_EQ(dds::make_encoder(*e)->encode(Region{}, bytes).message(), "a Region on a channel of Image");

  const dds::ChannelEncoding* j = dds::channel_encoding("JointState", true);
  EXPECT_EQ(j->schema_name, "sensor_msgs/msg/JointState");
  JointState state;
  state.position = {0.1, -0.2, 0.3, 0.0, 0.5};
  state.velocity = {1, 2, 3, 4, 5};
  ASSERT_TRUE(is_ok(dds::make_encoder(*j)->encode(state, bytes)));
  decoded = dds::make_decoder(*j)->decode(bytes.data(), bytes.size());
  ASSERT_TRUE(is_ok(decoded.status()));
  auto back = std::dynamic_pointer_cast<const JointState>(*decoded);
  ASSERT_NE(back, nullptr);
  EXPECT_EQ(back->position, state.position);
}

}  // namespace
}  // namespace saccade

namespace saccade {
namespace {

// Found by fuzz_channel: a Mat header with no data passed a null pointer to
// memcpy; headers no Mat can have made OpenCV throw or allocate gigabytes.
TEST(DdsWire, AMalformedMatHeaderIsUnreadable) {
  Image image;
  image.mat = cv::Mat(2, 3, CV_8UC1, cv::Scalar(5));
  std::vector<uint8_t> good;
  cdr::write(image, cdr::Envelope{}, good);
  // After the encapsulation (4), the stamp (48) and camera_id (4): rows, cols, type, byte count.
  constexpr std::size_t kRows = 56, kCols = 60, kType = 64, kCount = 68;
  auto read_with = [&](std::initializer_list<std::pair<std::size_t, int32_t>> patches) {
    std::vector<uint8_t> bytes = good;
    for (auto [at, value] : patches) std::memcpy(bytes.data() + at, &value, 4);
    Image out;
    cdr::Envelope envelope;
    return cdr::read(bytes.data(), bytes.size(), out, envelope).message();
  };
  ASSERT_EQ(read_with({}), "");
  EXPECT_THAT(read_with({{kCount, 0}}), ::testing::HasSubstr("is 6 bytes, not 0")) << "a header with no data";
  for (int32_t type : {-1, 1 << 20, CV_MAKETYPE(CV_8U, 600)})
    EXPECT_THAT(read_with({{kType, type}}), ::testing::HasSubstr("no matrix is 2x3")) << "type " << type;
  EXPECT_THAT(read_with({{kRows, 1 << 20}}), ::testing::HasSubstr("no matrix is")) << "a side past the limit";
  EXPECT_NE(read_with({{kRows, 60000}, {kCols, 60000}}), "") << "3.6 GB claimed, 6 bytes carried";
  EXPECT_THAT(read_with({{kCount, 1 << 30}}), ::testing::HasSubstr("bytes left")) << "a count past the end";
}

}  // namespace
}  // namespace saccade

namespace saccade {
namespace {

// Found by fuzz_channel: a ROS 2 image of some rows and no columns copied its
// rows into a Mat without data.
TEST(DdsRos2, AnImageWithoutColumnsOrRowsIsAnEmptyImage) {
  sensor_msgs::msg::dds_::Image_ wire;
  wire.encoding("mono8");
  wire.height(5);
  wire.width(0);
  wire.step(0);
  Image out;
  out.mat = cv::Mat(2, 2, CV_8UC1, cv::Scalar(7));
  EXPECT_TRUE(is_ok(dds::from_ros2(wire, out)));
  EXPECT_TRUE(out.mat.empty());
  wire.height(0);
  wire.width(4);
  wire.step(4);
  EXPECT_TRUE(is_ok(dds::from_ros2(wire, out)));
  EXPECT_TRUE(out.mat.empty());
}

// What logs write: images as ROS 2's (they lose nothing), joint states as
// saccade's own type, whose health, feedback times, error codes and cycle
// sensor_msgs/JointState has no field for: its IDL form, every field of which
// EveryDescribedFieldOfEveryTypeSurvivesItsChannel round-trips.
TEST(Channel, JointStatesAreWrittenWithEveryField) {
  EXPECT_EQ(dds::written_encoding("Image"), dds::channel_encoding("Image", true));
  EXPECT_EQ(dds::written_encoding("Image")->schema_name, "sensor_msgs/msg/Image");
  const dds::ChannelEncoding* j = dds::written_encoding("JointState");
  ASSERT_NE(j, nullptr);
  EXPECT_EQ(j, dds::channel_encoding("JointState", false));
  EXPECT_EQ(j->schema_encoding, "omgidl");
}

}  // namespace
}  // namespace saccade

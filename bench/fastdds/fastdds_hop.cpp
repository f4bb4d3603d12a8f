// The C++ Fast DDS baseline of radar_bench: one hop between two processes written against Fast DDS itself (the
// DDS under rclcpp's and rclpy's default rmw), plain or secured, built with g++ against Debian's Fast DDS 2.9
// (libfastrtps-dev, built with DDS Security) by the coordinator when a scenario needs it.
//
//   fastdds_hop sink   --topic T [--enclave DIR] [--transports udp|default]
//                      takes each std_msgs/msg/Header from a WaitSet's thread (as an rclcpp executor waits) and
//                      records its age
//   fastdds_hop source --topic T [--enclave DIR] [--transports udp|default]
//                      publishes stamped Headers
//
// T is the DDS topic name ("rt/bench/fastdds"). `--enclave DIR`: the participant is secured with the builtin
// PKI-DH, Access-Permissions and AES-GCM-GMAC plugins, configured from an enclave of an SROS2 keystore as
// rmw_fastrtps configures them (so the governance is the keystore's: the one radar_ros's secured rows use).
// `--transports udp` (the default): both roles use UDPv4 alone (Fast DDS's shared-memory transport is off), as
// RustDDS does. `--transports default`: Fast DDS's builtin transports, as an rclcpp or rclpy node runs them
// (shared memory between processes of one host, UDPv4 beside it). The QoS of a RADAR signal (reliable,
// volatile, keep-last 10: rclpy's default).
//
// Speaks radar_bench's child protocol (bench/src/proto.rs): prints `ready` once its endpoints exist, then
// answers one line per command on stdin: `wait` (source: a subscriber has matched), `run N PERIOD_US`
// (source: N stamped Headers, one every PERIOD_US from now), `report WARMUP` (sink: the ages of sequence
// numbers >= WARMUP, as JSON `{"lat_ns": [...], "received": K, "extra": {}}`), `quit`. Stamps are
// CLOCK_MONOTONIC nanoseconds, as the Rust and Python roles take them.
#include <time.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <iostream>
#include <memory>
#include <mutex>
#include <sstream>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include <fastdds/dds/core/condition/StatusCondition.hpp>
#include <fastdds/dds/core/condition/WaitSet.hpp>
#include <fastdds/dds/domain/DomainParticipant.hpp>
#include <fastdds/dds/domain/DomainParticipantFactory.hpp>
#include <fastdds/dds/publisher/DataWriter.hpp>
#include <fastdds/dds/publisher/Publisher.hpp>
#include <fastdds/dds/subscriber/DataReader.hpp>
#include <fastdds/dds/subscriber/SampleInfo.hpp>
#include <fastdds/dds/subscriber/Subscriber.hpp>
#include <fastdds/dds/topic/TopicDataType.hpp>
#include <fastdds/dds/topic/TypeSupport.hpp>
#include <fastdds/rtps/transport/UDPv4TransportDescriptor.h>

#include "../../tests/fastdds/security_properties.hpp"

using namespace eprosima::fastdds::dds;
using eprosima::fastdds::rtps::UDPv4TransportDescriptor;
using eprosima::fastrtps::rtps::InstanceHandle_t;
using eprosima::fastrtps::rtps::SerializedPayload_t;

static uint64_t now_ns() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<uint64_t>(ts.tv_sec) * 1000000000ull + static_cast<uint64_t>(ts.tv_nsec);
}

// std_msgs/msg/Header as rmw_fastrtps names and serializes it: stamp (int32 sec, uint32 nanosec), then
// frame_id (a CDR string: its length with the NUL, the bytes, the NUL), little endian. The bench puts the send
// time in the stamp and the sequence number in frame_id (bench/src/clock.rs `stamped`).
struct Header {
  int32_t sec = 0;
  uint32_t nanosec = 0;
  std::string frame_id;
};

static const uint32_t kMaxFrameId = 64;

class HeaderType : public TopicDataType {
 public:
  HeaderType() {
    setName("std_msgs::msg::dds_::Header_");
    m_typeSize = 4 + 8 + 4 + kMaxFrameId + 1 + 3;
    m_isGetKeyDefined = false;
  }
  bool serialize(void* data, SerializedPayload_t* payload) override {
    auto* h = static_cast<Header*>(data);
    if (h->frame_id.size() > kMaxFrameId) return false;
    uint8_t* p = payload->data;
    p[0] = 0;
    p[1] = 1;  // CDR_LE
    p[2] = 0;
    p[3] = 0;
    uint32_t len = static_cast<uint32_t>(h->frame_id.size()) + 1;
    std::memcpy(p + 4, &h->sec, 4);
    std::memcpy(p + 8, &h->nanosec, 4);
    std::memcpy(p + 12, &len, 4);
    std::memcpy(p + 16, h->frame_id.data(), len - 1);
    p[16 + len - 1] = 0;
    payload->length = 16 + len;
    payload->encapsulation = CDR_LE;
    return true;
  }
  bool deserialize(SerializedPayload_t* payload, void* data) override {
    auto* h = static_cast<Header*>(data);
    const uint8_t* p = payload->data;
    if (payload->length < 16 || p[1] != 1) return false;  // little endian only: both ends are this program
    uint32_t len = 0;
    std::memcpy(&h->sec, p + 4, 4);
    std::memcpy(&h->nanosec, p + 8, 4);
    std::memcpy(&len, p + 12, 4);
    if (len == 0 || len > kMaxFrameId + 1 || 16 + len > payload->length) return false;
    h->frame_id.assign(reinterpret_cast<const char*>(p + 16), len - 1);
    return true;
  }
  std::function<uint32_t()> getSerializedSizeProvider(void* data) override {
    auto* h = static_cast<Header*>(data);
    return [h]() -> uint32_t { return 4 + 12 + static_cast<uint32_t>(h->frame_id.size()) + 1; };
  }
  void* createData() override { return new Header(); }
  void deleteData(void* data) override { delete static_cast<Header*>(data); }
  bool getKey(void*, InstanceHandle_t*, bool) override { return false; }
};

static int usage() {
  std::fprintf(stderr, "usage: fastdds_hop sink|source --topic T [--enclave DIR] [--transports udp|default]\n");
  return 2;
}

int main(int argc, char** argv) {
  if (argc < 4) return usage();
  const std::string role = argv[1];
  std::string topic_name, enclave, transports = "udp";
  for (int i = 2; i + 1 < argc; i += 2) {
    const std::string k = argv[i];
    if (k == "--topic") {
      topic_name = argv[i + 1];
    } else if (k == "--enclave") {
      enclave = argv[i + 1];
    } else if (k == "--transports") {
      transports = argv[i + 1];
    } else {
      return usage();
    }
  }
  if ((role != "sink" && role != "source") || topic_name.empty()) return usage();
  if (transports != "udp" && transports != "default") return usage();
  const char* domain_env = std::getenv("ROS_DOMAIN_ID");
  const int domain = domain_env ? std::atoi(domain_env) : 0;

  DomainParticipantQos pqos = PARTICIPANT_QOS_DEFAULT;
  pqos.name("fastdds_hop_" + role);
  if (transports == "udp") {
    pqos.transport().use_builtin_transports = false;
    pqos.transport().user_transports.push_back(std::make_shared<UDPv4TransportDescriptor>());
  }
  if (!enclave.empty()) {
    add_security_properties(pqos, enclave);
  }
  DomainParticipant* participant =
      DomainParticipantFactory::get_instance()->create_participant(domain, pqos);
  if (participant == nullptr) {
    std::fprintf(stderr, "fastdds_hop: could not create a participant%s%s\n",
                 enclave.empty() ? "" : " secured from ", enclave.c_str());
    return 2;
  }
  TypeSupport type(new HeaderType());
  type.register_type(participant);
  Topic* topic = participant->create_topic(topic_name, type.get_type_name(), TOPIC_QOS_DEFAULT);
  DataWriter* writer = nullptr;
  DataReader* reader = nullptr;
  if (role == "source") {
    DataWriterQos q = DATAWRITER_QOS_DEFAULT;
    q.reliability().kind = RELIABLE_RELIABILITY_QOS;
    q.durability().kind = VOLATILE_DURABILITY_QOS;
    q.history().kind = KEEP_LAST_HISTORY_QOS;
    q.history().depth = 10;
    Publisher* pub = topic ? participant->create_publisher(PUBLISHER_QOS_DEFAULT) : nullptr;
    writer = pub ? pub->create_datawriter(topic, q) : nullptr;
  } else {
    DataReaderQos q = DATAREADER_QOS_DEFAULT;
    q.reliability().kind = RELIABLE_RELIABILITY_QOS;
    q.durability().kind = VOLATILE_DURABILITY_QOS;
    q.history().kind = KEEP_LAST_HISTORY_QOS;
    q.history().depth = 10;
    Subscriber* sub = topic ? participant->create_subscriber(SUBSCRIBER_QOS_DEFAULT) : nullptr;
    reader = sub ? sub->create_datareader(topic, q) : nullptr;
  }
  if (writer == nullptr && reader == nullptr) {
    std::fprintf(stderr, "fastdds_hop: could not create the %s of %s (permissions?)\n",
                 role == "source" ? "writer" : "reader", topic_name.c_str());
    return 2;
  }

  // the sink: one thread waits on the reader's data-available condition and takes what came
  std::mutex lock;
  std::vector<std::pair<uint64_t, uint64_t>> record;  // (sequence number, age in ns)
  std::atomic<bool> stop{false};
  std::thread taker;
  if (reader != nullptr) {
    taker = std::thread([&] {
      StatusCondition& cond = reader->get_statuscondition();
      cond.set_enabled_statuses(StatusMask::data_available());
      WaitSet ws;
      ws.attach_condition(cond);
      ConditionSeq active;
      Header h;
      SampleInfo info;
      while (!stop.load()) {
        ws.wait(active, eprosima::fastrtps::Duration_t(0, 100000000));
        while (reader->take_next_sample(&h, &info) == ReturnCode_t::RETCODE_OK) {
          if (!info.valid_data) continue;
          const uint64_t t = now_ns();
          const uint64_t sent =
              static_cast<uint64_t>(h.sec) * 1000000000ull + static_cast<uint64_t>(h.nanosec);
          const uint64_t seq = std::strtoull(h.frame_id.c_str(), nullptr, 10);
          std::lock_guard<std::mutex> g(lock);
          record.emplace_back(seq, t > sent ? t - sent : 0);
        }
      }
    });
  }

  std::printf("ready\n");
  std::fflush(stdout);
  std::string line;
  while (std::getline(std::cin, line)) {
    std::istringstream in(line);
    std::string cmd;
    if (!(in >> cmd)) continue;
    if (cmd == "quit") break;
    std::string answer;
    if (cmd == "wait" && writer != nullptr) {
      const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
      PublicationMatchedStatus st;
      answer = "error no subscriber within 20 s";
      while (std::chrono::steady_clock::now() < deadline) {
        writer->get_publication_matched_status(st);
        if (st.current_count > 0) {
          answer = "ok";
          break;
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
      }
    } else if (cmd == "run" && writer != nullptr) {
      uint64_t n = 0, period_us = 0;
      in >> n >> period_us;
      const auto start = std::chrono::steady_clock::now();
      Header h;
      for (uint64_t i = 0; i < n; ++i) {
        std::this_thread::sleep_until(start + std::chrono::microseconds(i * period_us));
        const uint64_t t = now_ns();
        h.sec = static_cast<int32_t>(t / 1000000000ull);
        h.nanosec = static_cast<uint32_t>(t % 1000000000ull);
        h.frame_id = std::to_string(i);
        writer->write(&h);
      }
      answer = "sent " + std::to_string(n);
    } else if (cmd == "report" && reader != nullptr) {
      uint64_t warmup = 0;
      in >> warmup;
      std::vector<std::pair<uint64_t, uint64_t>> got;
      {
        std::lock_guard<std::mutex> g(lock);
        got.swap(record);
      }
      std::ostringstream out;
      out << "{\"lat_ns\": [";
      bool first = true;
      for (const auto& [seq, age] : got) {
        if (seq < warmup) continue;
        out << (first ? "" : ",") << age;
        first = false;
      }
      out << "], \"received\": " << got.size() << ", \"extra\": {}}";
      answer = out.str();
    } else {
      answer = "error unknown command " + cmd + " for " + role;
    }
    std::printf("%s\n", answer.c_str());
    std::fflush(stdout);
  }
  stop.store(true);
  if (taker.joinable()) taker.join();
  participant->delete_contained_entities();
  DomainParticipantFactory::get_instance()->delete_participant(participant);
  return 0;
}

// A secured Fast DDS peer for radar_ros's DDS Security interop test (radar_ros/library/tests/secure.rs), built against
// Debian's Fast DDS 2.9 (libfastrtps-dev, compiled with DDS Security): the builtin plugins PKI-DH,
// Access-Permissions and AES-GCM-GMAC, configured from an enclave of a keystore made by radar_ros, as
// rmw_fastrtps configures them from an SROS2 enclave.
//
//   secure_peer ENCLAVE_DIR DOMAIN START_TOPIC EXITED_TOPIC TIMEOUT_S
//
// Publishes std_msgs/msg/Empty on START_TOPIC (a DDS name, "rt/dock/start") every 200 ms once a secured
// subscriber has matched, until one sample arrives on EXITED_TOPIC; prints what happens, one line per step
// ("matched start", "exited received"), and exits 0 then, 1 on timeout, 2 if it cannot start.
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <thread>

#include <fastdds/dds/domain/DomainParticipant.hpp>
#include <fastdds/dds/domain/DomainParticipantFactory.hpp>
#include <fastdds/dds/publisher/DataWriter.hpp>
#include <fastdds/dds/publisher/Publisher.hpp>
#include <fastdds/dds/subscriber/DataReader.hpp>
#include <fastdds/dds/subscriber/SampleInfo.hpp>
#include <fastdds/dds/subscriber/Subscriber.hpp>
#include <fastdds/dds/topic/TopicDataType.hpp>
#include <fastdds/dds/topic/TypeSupport.hpp>

#include "security_properties.hpp"

using namespace eprosima::fastdds::dds;
using eprosima::fastrtps::rtps::InstanceHandle_t;
using eprosima::fastrtps::rtps::SerializedPayload_t;

// std_msgs/msg/Empty as rmw_fastrtps names and serializes it: one uint8, CDR little endian.
struct Empty {
  uint8_t structure_needs_at_least_one_member = 0;
};

class EmptyType : public TopicDataType {
 public:
  EmptyType() {
    setName("std_msgs::msg::dds_::Empty_");
    m_typeSize = 8;
    m_isGetKeyDefined = false;
  }
  bool serialize(void* data, SerializedPayload_t* payload) override {
    payload->data[0] = 0;
    payload->data[1] = 1;  // CDR_LE
    payload->data[2] = 0;
    payload->data[3] = 0;
    payload->data[4] = static_cast<Empty*>(data)->structure_needs_at_least_one_member;
    payload->length = 5;
    payload->encapsulation = CDR_LE;
    return true;
  }
  bool deserialize(SerializedPayload_t* payload, void* data) override {
    if (payload->length < 5) return false;
    static_cast<Empty*>(data)->structure_needs_at_least_one_member = payload->data[4];
    return true;
  }
  std::function<uint32_t()> getSerializedSizeProvider(void*) override {
    return []() -> uint32_t { return 8; };
  }
  void* createData() override { return new Empty(); }
  void deleteData(void* data) override { delete static_cast<Empty*>(data); }
  bool getKey(void*, InstanceHandle_t*, bool) override { return false; }
};

int main(int argc, char** argv) {
  if (argc != 6) {
    std::fprintf(stderr, "usage: secure_peer ENCLAVE_DIR DOMAIN START_TOPIC EXITED_TOPIC TIMEOUT_S\n");
    return 2;
  }
  const std::string enclave = argv[1];
  const int domain = std::atoi(argv[2]);
  const std::string start_topic = argv[3], exited_topic = argv[4];
  const int timeout_s = std::atoi(argv[5]);

  DomainParticipantQos pqos = PARTICIPANT_QOS_DEFAULT;
  pqos.name("fastdds_secure_peer");
  add_security_properties(pqos, enclave);

  DomainParticipant* participant =
      DomainParticipantFactory::get_instance()->create_participant(domain, pqos);
  if (participant == nullptr) {
    std::fprintf(stderr, "could not create a secured participant from %s\n", enclave.c_str());
    return 2;
  }
  TypeSupport type(new EmptyType());
  type.register_type(participant);
  Topic* start = participant->create_topic(start_topic, type.get_type_name(), TOPIC_QOS_DEFAULT);
  Topic* exited = participant->create_topic(exited_topic, type.get_type_name(), TOPIC_QOS_DEFAULT);
  Publisher* pub = participant->create_publisher(PUBLISHER_QOS_DEFAULT);
  Subscriber* sub = participant->create_subscriber(SUBSCRIBER_QOS_DEFAULT);
  DataWriterQos wqos = DATAWRITER_QOS_DEFAULT;
  wqos.reliability().kind = RELIABLE_RELIABILITY_QOS;
  DataReaderQos rqos = DATAREADER_QOS_DEFAULT;
  rqos.reliability().kind = RELIABLE_RELIABILITY_QOS;
  DataWriter* writer = start && pub ? pub->create_datawriter(start, wqos) : nullptr;
  DataReader* reader = exited && sub ? sub->create_datareader(exited, rqos) : nullptr;
  if (writer == nullptr || reader == nullptr) {
    std::fprintf(stderr, "could not create the writer of %s or the reader of %s (permissions?)\n",
                 start_topic.c_str(), exited_topic.c_str());
    return 2;
  }

  const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(timeout_s);
  bool matched = false;
  int rc = 1;
  while (std::chrono::steady_clock::now() < end) {
    PublicationMatchedStatus st;
    writer->get_publication_matched_status(st);
    if (!matched && st.current_count > 0) {
      matched = true;
      std::printf("matched start\n");
      std::fflush(stdout);
    }
    if (matched) {
      Empty e;
      writer->write(&e);
    }
    Empty got;
    SampleInfo info;
    if (reader->take_next_sample(&got, &info) == ReturnCode_t::RETCODE_OK && info.valid_data) {
      std::printf("exited received\n");
      std::fflush(stdout);
      rc = 0;
      break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
  }
  if (rc != 0) {
    std::printf("timed out (%s)\n", matched ? "matched, no exited" : "never matched");
  }
  participant->delete_contained_entities();
  DomainParticipantFactory::get_instance()->delete_participant(participant);
  return rc;
}

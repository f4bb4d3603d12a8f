// DDS Security for a Fast DDS participant from an enclave of an SROS2 keystore, as rmw_fastrtps configures it:
// the builtin PKI-DH, Access-Permissions and AES-GCM-GMAC plugins, their files taken from ENCLAVE_DIR. Shared
// by the secured Fast DDS peer of radar_ros's interop test (secure_peer.cpp) and the Fast DDS baseline of
// radar_bench (bench/fastdds/fastdds_hop.cpp).
#pragma once

#include <string>

#include <fastdds/dds/domain/qos/DomainParticipantQos.hpp>

inline void add_security_properties(eprosima::fastdds::dds::DomainParticipantQos& pqos,
                                    const std::string& enclave) {
  auto& props = pqos.properties().properties();
  auto file = [&](const char* f) { return "file://" + enclave + "/" + f; };
  props.emplace_back("dds.sec.auth.plugin", "builtin.PKI-DH");
  props.emplace_back("dds.sec.auth.builtin.PKI-DH.identity_ca", file("identity_ca.cert.pem"));
  props.emplace_back("dds.sec.auth.builtin.PKI-DH.identity_certificate", file("cert.pem"));
  props.emplace_back("dds.sec.auth.builtin.PKI-DH.private_key", file("key.pem"));
  props.emplace_back("dds.sec.access.plugin", "builtin.Access-Permissions");
  props.emplace_back("dds.sec.access.builtin.Access-Permissions.permissions_ca",
                     file("permissions_ca.cert.pem"));
  props.emplace_back("dds.sec.access.builtin.Access-Permissions.governance", file("governance.p7s"));
  props.emplace_back("dds.sec.access.builtin.Access-Permissions.permissions", file("permissions.p7s"));
  props.emplace_back("dds.sec.crypto.plugin", "builtin.AES-GCM-GMAC");
}

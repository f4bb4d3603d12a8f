use bytes::Bytes;
use enumflags2::BitFlags;
use speedy::{Readable, Writable};
use log::{debug, warn};

use crate::{
  create_security_error_and_log,
  messages::submessages::{
    elements::{
      crypto_content::CryptoContent, crypto_footer::CryptoFooter, crypto_header::CryptoHeader,
      parameter_list::ParameterList,
    },
    info_source::InfoSource,
    secure_body::SecureBody,
    secure_postfix::SecurePostfix,
    secure_prefix::SecurePrefix,
    secure_rtps_postfix::SecureRTPSPostfix,
    secure_rtps_prefix::SecureRTPSPrefix,
    submessage::SecuritySubmessage,
    submessage_flag::FromEndianness,
    submessages::InterpreterSubmessage,
  },
  rtps::{Message, Submessage, SubmessageBody},
  security::cryptographic::cryptographic_builtin::*,
};
use super::{
  aes_gcm_gmac::{compute_mac, decrypt, encrypt_in_place, validate_mac},
  encode::{encode_gcm, encode_gmac},
  key_material::*,
  validate_receiver_specific_macs::validate_receiver_specific_mac,
};

impl CryptographicBuiltin {
  fn encode_submessage(
    &self,
    plain_rtps_submessage: Submessage,
    sending_endpoint_crypto_handle: EndpointCryptoHandle,
    receiving_endpoint_crypto_handle_list: &[EndpointCryptoHandle],
  ) -> SecurityResult<EncodedSubmessage> {
    // Serialize plaintext
    // TODO: Do we respect RTPS endianness here? I.e. used and flagged encodings
    // match?
    let plaintext = plain_rtps_submessage.to_bytes_fast().map_err(|err| {
      create_security_error_and_log!("Error converting Submessage to byte vector: {}", err)
    })?;

    // Get the key material for encoding
    let EncodeSessionMaterials {
      key_id,
      transformation_kind,
      session_key,
      initialization_vector,
      receiver_specific_keys,
    } = self.session_encoding_materials(
      sending_endpoint_crypto_handle,
      KeyMaterialScope::MessageOrSubmessage,
      receiving_endpoint_crypto_handle_list,
    )?;

    // Compute encoded submessage and footer

    let (encoded_submessage, crypto_footer) = match transformation_kind {
      BuiltinCryptoTransformationKind::CRYPTO_TRANSFORMATION_KIND_NONE => {
        return Ok(EncodedSubmessage::Unencoded(plain_rtps_submessage))
      }
      BuiltinCryptoTransformationKind::CRYPTO_TRANSFORMATION_KIND_AES128_GMAC
      | BuiltinCryptoTransformationKind::CRYPTO_TRANSFORMATION_KIND_AES256_GMAC => (
        plain_rtps_submessage,
        encode_gmac(
          &session_key,
          initialization_vector,
          &plaintext,
          &receiver_specific_keys,
        )?,
      ),
      BuiltinCryptoTransformationKind::CRYPTO_TRANSFORMATION_KIND_AES128_GCM
      | BuiltinCryptoTransformationKind::CRYPTO_TRANSFORMATION_KIND_AES256_GCM => encode_gcm(
        &session_key,
        initialization_vector,
        plaintext,
        &receiver_specific_keys,
      )?,
    };

    // Build crypto header and security prefix
    let prefix = SecurePrefix {
      crypto_header: CryptoHeader::from(BuiltinCryptoHeader {
        transform_identifier: BuiltinCryptoTransformIdentifier {
          transformation_kind,
          transformation_key_id: key_id,
        },
        builtin_crypto_header_extra: initialization_vector.into(),
      }),
    };

    // Build security postfix
    let postfix = SecurePostfix {
      crypto_footer: CryptoFooter::try_from(crypto_footer)?,
    };

    Ok(EncodedSubmessage::Encoded(
      prefix.create_submessage(speedy::Endianness::BigEndian)?, // 9.5.2.3 use BigEndian
      encoded_submessage,
      postfix.create_submessage(speedy::Endianness::BigEndian)?, // 9.5.2.5 use BigEndian
    ))
  }
}

impl CryptoTransform for CryptographicBuiltin {
  fn encode_serialized_payload(
    &self,
    plain_buffer: Vec<u8>,
    sending_datawriter_crypto_handle: DatawriterCryptoHandle,
  ) -> SecurityResult<(Vec<u8>, ParameterList)> {
    // Get the key material for encrypting serialized payloads
    let EncodeSessionMaterials {
      key_id,
      transformation_kind,
      session_key,
      initialization_vector,
      ..
    } = self.session_encoding_materials(
      sending_datawriter_crypto_handle,
      KeyMaterialScope::PayloadOnly,
      &[],
    )?;

    // Receiver specific (signing) keys are not used.
    //
    // DDS Security spec, Section9.5.3.3.1 Overview, Table 72:
    // [The encode_serialized_payload] operation shall always set the
    // receiver_specific_macs attribute in the CryptoFooter to the empty
    // sequence.

    let header = BuiltinCryptoHeader {
      transform_identifier: BuiltinCryptoTransformIdentifier {
        transformation_kind,
        transformation_key_id: key_id,
      },
      builtin_crypto_header_extra: initialization_vector.into(),
    };

    if let BuiltinCryptoTransformationKind::CRYPTO_TRANSFORMATION_KIND_NONE = transformation_kind {
      return Ok((plain_buffer, ParameterList::new()));
    }

    // The header, the payload (signed) or its CryptoContent (encrypted where it is written), and the footer,
    // written into one buffer (RADAR patch 67: the plaintext was copied to be encrypted, the ciphertext to
    // be a CryptoContent, and the three parts once more to be concatenated)
    let mut encoded = Vec::with_capacity(
      BuiltinCryptoHeader::serialized_len()
        + 4
        + plain_buffer.len()
        + BuiltinCryptoFooter::minimal_serialized_len(),
    );
    CryptoHeader::from(header)
      .write_to_stream(&mut encoded)
      .map_err(|err| {
        create_security_error_and_log!("Error converting CryptoHeader to byte vector: {}", err)
      })?;
    let footer = match transformation_kind {
      BuiltinCryptoTransformationKind::CRYPTO_TRANSFORMATION_KIND_AES128_GCM
      | BuiltinCryptoTransformationKind::CRYPTO_TRANSFORMATION_KIND_AES256_GCM => {
        // CryptoContent: a big-endian length (9.5.2.4), then the ciphertext, as long as the plaintext
        let length = u32::try_from(plain_buffer.len()).map_err(|_| {
          create_security_error_and_log!("Error converting CryptoContent to byte vector: too long")
        })?;
        encoded.extend_from_slice(&length.to_be_bytes());
        let start = encoded.len();
        encoded.extend_from_slice(&plain_buffer);
        let mac = encrypt_in_place(&session_key, initialization_vector, &mut encoded[start..])?;
        BuiltinCryptoFooter::only_common_mac(mac)
      }
      // AES128_GMAC, AES256_GMAC (NONE returned above)
      _ => {
        let mac = compute_mac(&session_key, initialization_vector, &plain_buffer)?;
        encoded.extend_from_slice(&plain_buffer);
        BuiltinCryptoFooter::only_common_mac(mac)
      }
    };
    footer.append_to(&mut encoded)?;
    Ok((
      encoded,
      ParameterList::new(),
      // TODO: If the payload was not data but key, then construct a key_hash
      // and return that to be appended to the InlineQoS of the outgoing DATA Submessage.
      // Encrypted payloads must have their key sent as hash only (in InlineQoS), never plaintext.
    ))
  }

  fn encode_datawriter_submessage(
    &self,
    plain_rtps_submessage: Submessage,
    sending_datawriter_crypto_handle: DatawriterCryptoHandle,
    receiving_datareader_crypto_handle_list: Vec<DatareaderCryptoHandle>,
  ) -> SecurityResult<EncodedSubmessage> {
    self.encode_submessage(
      plain_rtps_submessage,
      sending_datawriter_crypto_handle,
      &receiving_datareader_crypto_handle_list,
    )
  }

  fn encode_datareader_submessage(
    &self,
    plain_rtps_submessage: Submessage,
    sending_datareader_crypto_handle: DatareaderCryptoHandle,
    receiving_datawriter_crypto_handle_list: Vec<DatawriterCryptoHandle>,
  ) -> SecurityResult<EncodedSubmessage> {
    self.encode_submessage(
      plain_rtps_submessage,
      sending_datareader_crypto_handle,
      &receiving_datawriter_crypto_handle_list,
    )
  }

  fn encode_rtps_message(
    &self,
    Message {
      header,
      submessages,
    }: Message,
    sending_participant_crypto_handle: ParticipantCryptoHandle,
    receiving_participant_crypto_handle_list: Vec<ParticipantCryptoHandle>,
  ) -> SecurityResult<Message> {
    // Convert the header into an InfoSource submessage
    let info_source = InfoSource::from(header)
      .create_submessage(BitFlags::from_endianness(speedy::Endianness::BigEndian));

    // Serialize plaintext: the InfoSource, then the submessages one after another, in one buffer (RADAR patch
    // 64). The submessages are read where they are: not cloned, with the InfoSource, into a new Vec first
    // (RADAR patch 67).
    let mut plaintext = Vec::with_capacity(
      4 + info_source.header.content_length as usize
        + submessages
          .iter()
          .map(|s| 4 + s.header.content_length as usize)
          .sum::<usize>(),
    );
    for submessage in std::iter::once(&info_source).chain(&submessages) {
      submessage.append_to(&mut plaintext).map_err(|err| {
        create_security_error_and_log!("Error converting Submessage to byte vector: {}", err)
      })?;
    }

    // Get the key material for encoding
    let EncodeSessionMaterials {
      key_id,
      transformation_kind,
      session_key,
      initialization_vector,
      receiver_specific_keys,
    } = self.session_encoding_materials(
      sending_participant_crypto_handle,
      KeyMaterialScope::MessageOrSubmessage,
      &receiving_participant_crypto_handle_list,
    )?;

    // Compute the footer and what goes between the prefix and the postfix: with GMAC the InfoSource and the
    // submessages as they were, with GCM one SecureBody
    let (secure_body, crypto_footer) = match transformation_kind {
      BuiltinCryptoTransformationKind::CRYPTO_TRANSFORMATION_KIND_NONE => {
        return Err(create_security_error_and_log!(
          "encode_rtps_message called when transformation kind is NONE."
        ));
      }
      BuiltinCryptoTransformationKind::CRYPTO_TRANSFORMATION_KIND_AES128_GMAC
      | BuiltinCryptoTransformationKind::CRYPTO_TRANSFORMATION_KIND_AES256_GMAC => (
        None,
        encode_gmac(
          &session_key,
          initialization_vector,
          &plaintext,
          &receiver_specific_keys,
        )?,
      ),
      BuiltinCryptoTransformationKind::CRYPTO_TRANSFORMATION_KIND_AES128_GCM
      | BuiltinCryptoTransformationKind::CRYPTO_TRANSFORMATION_KIND_AES256_GCM => {
        let (secure_body_submessage, footer) = encode_gcm(
          &session_key,
          initialization_vector,
          plaintext,
          &receiver_specific_keys,
        )?;
        (Some(secure_body_submessage), footer)
      }
    };

    // Build crypto header and security prefix
    let prefix = SecureRTPSPrefix {
      crypto_header: CryptoHeader::from(BuiltinCryptoHeader {
        transform_identifier: BuiltinCryptoTransformIdentifier {
          transformation_kind,
          transformation_key_id: key_id,
        },
        builtin_crypto_header_extra: initialization_vector.into(),
      }),
    };

    // Build security postfix
    let postfix = SecureRTPSPostfix {
      crypto_footer: CryptoFooter::try_from(crypto_footer)?,
    };

    // The message, built once in place (it was concatenated from three Vecs and copied again, RADAR patch 67)
    let between = if secure_body.is_some() {
      1
    } else {
      1 + submessages.len()
    };
    let mut encoded = Vec::with_capacity(2 + between);
    encoded.push(prefix.create_submessage(speedy::Endianness::BigEndian)?); // 9.5.2.3 use BigEndian
    match secure_body {
      Some(secure_body_submessage) => encoded.push(secure_body_submessage),
      None => {
        encoded.push(info_source);
        encoded.extend(submessages);
      }
    }
    encoded.push(postfix.create_submessage(speedy::Endianness::BigEndian)?); // 9.5.2.5 use BigEndian

    Ok(Message {
      header,
      submessages: encoded,
    })
  }

  fn decode_rtps_message(
    &self,
    Message {
      header: rtps_header,
      mut submessages,
    }: Message,
    _receiving_participant_crypto_handle: ParticipantCryptoHandle,
    sending_participant_crypto_handle: ParticipantCryptoHandle,
  ) -> SecurityResult<DecodeOutcome<Message>> {
    // we expect SecureRTPSPRefix + some submessages + SecureRTPSPostfix
    if let
      [ Submessage { body:
          SubmessageBody::Security(SecuritySubmessage::SecureRTPSPrefix(
            SecureRTPSPrefix { crypto_header, .. }, _, )), .. },

        encoded_content @ ..,
        // ^ Note: This `..` is a "rest" pattern! Matches all submessages between first and last,

        Submessage { body:
          SubmessageBody::Security(SecuritySubmessage::SecureRTPSPostfix(
            SecureRTPSPostfix { crypto_footer }, _, )), .. }
      ] = submessages.as_mut_slice()
    {
      let BuiltinCryptoHeader {
        transform_identifier:
          BuiltinCryptoTransformIdentifier {
            transformation_kind: header_transformation_kind,
            transformation_key_id,
          },
        builtin_crypto_header_extra: BuiltinCryptoHeaderExtra(initialization_vector),
      } = BuiltinCryptoHeader::try_from(crypto_header.clone())?;

      let BuiltinCryptoFooter { common_mac, receiver_specific_macs }
        = BuiltinCryptoFooter::try_from(crypto_footer.clone())?;

      // Get decode key material
      let decode_key_material = match self.get_session_decode_crypto_materials(
        sending_participant_crypto_handle,
        transformation_key_id,
        KeyMaterialScope::MessageOrSubmessage,
        initialization_vector,
      ){
        Some(decode_key_material)=>decode_key_material,
        None=> return Ok(DecodeOutcome::KeysNotFound(transformation_key_id))
      };

      // Check that the key id matches the header
      if transformation_key_id != decode_key_material.key_id {
        Err(create_security_error_and_log!(
          "The key IDs don't match. The key material has sender_key_id {}, while the header has \
           transformation_key_id {}",
          decode_key_material.key_id,
          transformation_key_id
        ))?;
      } else if header_transformation_kind != decode_key_material.transformation_kind {
        Err(create_security_error_and_log!(
          "The transformation_kind don't match. The key material has {:?}, while the header has \
           {:?}",
          decode_key_material.transformation_kind,
          header_transformation_kind
        ))?;
      }

      let decode_key = &decode_key_material.session_key;

      match decode_key_material.transformation_kind {
        BuiltinCryptoTransformationKind::CRYPTO_TRANSFORMATION_KIND_NONE =>{
          let submessages_with_info_source: &[Submessage] = encoded_content; // rename for clarity
          // We expect an InfoSource submessage followed by the original message
          if let
            [ Submessage { body: SubmessageBody::Interpreter(
                InterpreterSubmessage::InfoSource(info_source, _)), .. },
              submessages @ ..  // this is all the rest of the submessages
            ] = submessages_with_info_source
          {
            Ok((submessages.to_vec(), *info_source))
          } else {
            Err(create_security_error_and_log!("Expected the first submessage to be InfoSource."))
          }
        }
        BuiltinCryptoTransformationKind::CRYPTO_TRANSFORMATION_KIND_AES128_GMAC
        | BuiltinCryptoTransformationKind::CRYPTO_TRANSFORMATION_KIND_AES256_GMAC => {
          let submessages_with_info_source: &[Submessage] = encoded_content; // rename for clarity
          // We expect an InfoSource submessage followed by the original message
          if let
            [ Submessage { body: SubmessageBody::Interpreter(
                InterpreterSubmessage::InfoSource(info_source, _)), .. },
              submessages @ ..  // this is all the rest of the submessages
            ] = submessages_with_info_source
          {
            // Get original serialized data for submessage sequence: Concatenate original_bytes.
            let serialized_submessages = submessages_with_info_source.iter()
              .fold(Vec::<u8>::with_capacity(512), move |mut a,s| {
                a.extend_from_slice(s.original_bytes.as_ref().unwrap_or(&Bytes::new()).as_ref()); a }
              );

            // Validate receiver-specific MAC if one is expected
            if !validate_receiver_specific_mac(&decode_key_material,&initialization_vector,&common_mac,&receiver_specific_macs){
              return Ok(DecodeOutcome::ValidatingReceiverSpecificMACFailed);
            }
            // Validate the common MAC
            validate_mac(decode_key, initialization_vector, &serialized_submessages, common_mac)
              // If the MACs are ok, return content. 
              .map( |_| (submessages.to_vec(), *info_source))
          } else {
            Err(create_security_error_and_log!("Expected the first submessage to be InfoSource."))
          }
        }
        BuiltinCryptoTransformationKind::CRYPTO_TRANSFORMATION_KIND_AES128_GCM
        | BuiltinCryptoTransformationKind::CRYPTO_TRANSFORMATION_KIND_AES256_GCM => {
          // We expect a SecureBody submessage containing the encrypted message
          if let [ Submessage { body: SubmessageBody::Security(SecuritySubmessage::SecureBody(
                    SecureBody { crypto_content: CryptoContent { data: ciphertext },}, _ )), ..  }
            ] = encoded_content
          {
            // Validate receiver-specific MAC if one is expected
            if !validate_receiver_specific_mac(&decode_key_material,&initialization_vector,&common_mac,&receiver_specific_macs){
              return Ok(DecodeOutcome::ValidatingReceiverSpecificMACFailed);
            }
            // Authenticated decryption in the ciphertext's own buffer, taken from the submessage (it is not
            // looked at again), or exit on failure (RADAR patch 67: copied twice before)
            let mut plaintext = Bytes::from(decrypt(
              decode_key,
              initialization_vector,
              std::mem::take(ciphertext),
              common_mac,
            )?);

            // We expect an InfoSource submessage followed by the original submessage sequence
            let info_source =
              if let Some(Submessage {body: SubmessageBody::Interpreter(
                    InterpreterSubmessage::InfoSource(info_source, _)), .. })
                  = Submessage::read_from_buffer(&mut plaintext)
                      .map_err(|e| create_security_error_and_log!("Failed to deserialize the plaintext: {e}"))?
              {
                info_source
              } else {
                Err(create_security_error_and_log!("Expected the first decrypted submessage to be InfoSource."))?
              };

            // Room for a sample's submessages (INFO_DST, INFO_TS and a secured DATA and HEARTBEAT, say) at
            // once: not grown from none through 4 to 8 (RADAR patch 67)
            let mut submessages = Vec::<Submessage>::with_capacity(8);
            while !plaintext.is_empty() {
              if let Some(submessage) = Submessage::read_from_buffer(&mut plaintext)
                .map_err(|e| create_security_error_and_log!("Failed to deserialize the plaintext: {e}"))?
              {
                submessages.push(submessage);
              }
            }

            Ok((submessages, info_source))
          } else {
            Err(create_security_error_and_log!("Expected only a SecureBody submessage."))
          }
        }
      }
      .and_then( |(submessages, info_source)| {
        if InfoSource::from(rtps_header) == info_source {
          Ok(DecodeOutcome::Success(Message { header: rtps_header, submessages }))
        } else {
          Err(create_security_error_and_log!(
            "The RTPS header did not match the encoded InfoSource: {:?} expected to match {:?}",
            info_source, rtps_header))
        }
      })
    } else {
      Err(create_security_error_and_log!(
        "Expected the first submessage to be SecureRTPSPrefix and the last SecureRTPSPostfix"
      ))
    }
  }

  fn decode_submessage(
    &self,
    encoded_rtps_submessage: (SecurePrefix, Submessage, SecurePostfix),
    _receiving_local_participant_crypto_handle: ParticipantCryptoHandle,
    sending_remote_participant_crypto_handle: ParticipantCryptoHandle,
  ) -> SecurityResult<DecodeOutcome<DecodedSubmessage>> {
    // Destructure header and footer
    let (SecurePrefix { crypto_header }, encoded_submessage, SecurePostfix { crypto_footer }) =
      encoded_rtps_submessage;

    let BuiltinCryptoHeader {
      transform_identifier:
        BuiltinCryptoTransformIdentifier {
          transformation_kind: header_transformation_kind,
          transformation_key_id: header_key_id,
        },
      builtin_crypto_header_extra: BuiltinCryptoHeaderExtra(initialization_vector),
    } = BuiltinCryptoHeader::try_from(crypto_header)?;

    let BuiltinCryptoFooter {
      common_mac,
      receiver_specific_macs,
    } = BuiltinCryptoFooter::try_from(crypto_footer)?;

    // Search for matching key materials over endpoints registered to the sender. A sender with no registered
    // endpoints (none matched yet, or a peer that is leaving: its endpoints go before its participant does, and
    // its last submessages are still on their way) has no keys to decode with, as one whose endpoints were all
    // unregistered: not an error (RADAR patch 31).
    if !self
      .participant_to_endpoint_info
      .contains_key(&sending_remote_participant_crypto_handle)
    {
      debug!(
        "No registered entities for the sending remote participant {}: no keys for the submessage",
        sending_remote_participant_crypto_handle
      );
      return Ok(DecodeOutcome::KeysNotFound(header_key_id));
    }

    // The candidates are the sender's endpoints whose key has the header's key id, from the index (RADAR patch
    // 65; trying every endpoint of the sender cost a lookup per endpoint per submessage). Several under one key
    // id are one remote endpoint matched with several local ones (a remote reader has a handle per local writer
    // it matched, patch 27): one master key, so one session key, derived for the first and shared by those with
    // the same master key and salt.
    let mut first_derived: Option<(&KeyMaterial_AES_GCM_GMAC, SessionKey)> = None;
    let matching_decode_materials = self
      .endpoints_with_decode_key(sending_remote_participant_crypto_handle, header_key_id)
      .iter()
      .filter_map(|sending_endpoint_info| {
        let key_material = self.get_decode_key_material(
          sending_endpoint_info.crypto_handle,
          header_key_id,
          KeyMaterialScope::MessageOrSubmessage,
        )?;
        let shared = first_derived
          .as_ref()
          .filter(|(first, _)| {
            first.master_sender_key == key_material.master_sender_key
              && first.master_salt == key_material.master_salt
              && first.transformation_kind == key_material.transformation_kind
          })
          .map(|(_, session_key)| session_key.clone());
        // With origin authentication, only an endpoint whose receiver-specific key id the footer carries a MAC for
        // can pass the receiver-specific check: the others' receiver-specific keys are not derived (one remote
        // reader matched with many local writers sends each ACKNACK to one of them)
        let addressed = key_material.receiver_specific_key_id.is_zero()
          || receiver_specific_macs
            .iter()
            .any(|m| m.receiver_mac_key_id == key_material.receiver_specific_key_id);
        let decode_materials = Self::session_decode_materials(
          key_material,
          initialization_vector,
          shared,
          addressed,
        );
        if first_derived.is_none() {
          first_derived = Some((key_material, decode_materials.session_key.clone()));
        }
        Some((decode_materials, sending_endpoint_info, addressed))
      })
      .collect::<Vec<_>>();

    let decode_key = matching_decode_materials
      .iter()
      // Check that for all matched ids transformation kind matches the header
      .map(
        |(
          DecodeSessionMaterials {
            transformation_kind,
            session_key,
            ..
          },
          _,
          _,
        )| {
          if transformation_kind.eq(&header_transformation_kind) {
            Ok(session_key)
          } else {
            Err(create_security_error_and_log!(
              "Transformation kind of the submessage header does not match the key: expected \
               {:?}, received {:?}.",
              transformation_kind,
              header_transformation_kind
            ))
          }
        },
      )
      // Make sure the key is unambiguous
      .reduce(|accumulator, session_key_result| {
        accumulator.and_then(|acc_session_key| {
          session_key_result.and_then(|current_session_key| {
            if acc_session_key.eq(current_session_key) {
              Ok(acc_session_key)
            } else {
              Err(create_security_error_and_log!(
                "Multiple different matching decode keys found for the key id {:?} for the remote \
                 participant {}",
                header_key_id,
                sending_remote_participant_crypto_handle
              ))
            }
          })
        })
      });

    let decode_key = match decode_key {
      Some(key_result) => key_result?,
      None => {
        return Ok(DecodeOutcome::KeysNotFound(header_key_id));
      }
    };

    let (decoded_submessage, sending_endpoint_infos) = match header_transformation_kind {
      BuiltinCryptoTransformationKind::CRYPTO_TRANSFORMATION_KIND_NONE => {
        // Does this even make sense?
        warn!("Decode submessage success, but crypto transformation kind is none.");

        let sending_endpoint_infos = matching_decode_materials
          .iter()
          .map(|(_, sending_endpoint_info, _)| sending_endpoint_info)
          .collect::<Vec<_>>();

        (encoded_submessage.body, sending_endpoint_infos)
      }
      BuiltinCryptoTransformationKind::CRYPTO_TRANSFORMATION_KIND_AES128_GMAC
      | BuiltinCryptoTransformationKind::CRYPTO_TRANSFORMATION_KIND_AES256_GMAC => {
        if let Submessage {
          original_bytes: Some(data),
          ..
        } = encoded_submessage
        {
          // Check receiver-specific MACS and filter the list of endpoints by them
          let sending_endpoint_infos = matching_decode_materials
            .iter()
            .filter_map(|(decode_materials, sending_endpoint_info, addressed)| {
              (*addressed
                && validate_receiver_specific_mac(
                  decode_materials,
                  &initialization_vector,
                  &common_mac,
                  &receiver_specific_macs,
                ))
              .then_some(sending_endpoint_info)
            })
            .collect::<Vec<_>>();

          validate_mac(decode_key, initialization_vector, &data, common_mac)?; // return verify error here, or continue

          (encoded_submessage.body, sending_endpoint_infos)
        } else {
          Err(create_security_error_and_log!(
            "Submessage bytes are missing."
          ))?
        }
      }
      BuiltinCryptoTransformationKind::CRYPTO_TRANSFORMATION_KIND_AES128_GCM
      | BuiltinCryptoTransformationKind::CRYPTO_TRANSFORMATION_KIND_AES256_GCM => {
        // Destructure to get ciphertext
        if let Submessage {
          body:
            SubmessageBody::Security(SecuritySubmessage::SecureBody(
              SecureBody {
                crypto_content: CryptoContent { data: ciphertext },
              },
              _,
            )),
          ..
        } = encoded_submessage
        {
          // Check receiver-specific MACS and filter the list of endpoints by them
          let sending_endpoint_infos = matching_decode_materials
            .iter()
            .filter_map(|(decode_materials, sending_endpoint_info, addressed)| {
              (*addressed
                && validate_receiver_specific_mac(
                  decode_materials,
                  &initialization_vector,
                  &common_mac,
                  &receiver_specific_macs,
                ))
              .then_some(sending_endpoint_info)
            })
            .collect::<Vec<_>>();

          // Authenticated decryption, in the ciphertext's own buffer (RADAR patch 67: copied twice before)
          let mut plaintext = Bytes::from(decrypt(
            decode_key,
            initialization_vector,
            ciphertext,
            common_mac,
          )?);

          // Deserialize (submessage deserialization is a bit funky atm)
          let decoded_submessage =
            match Submessage::read_from_buffer(&mut plaintext).map_err(|e| {
              create_security_error_and_log!("Failed to deserialize the plaintext: {}", e)
            })? {
              Some(Submessage { body, .. }) => body,
              None => Err(create_security_error_and_log!(
                "Failed to deserialize the plaintext into a submessage. It could have been PAD or \
                 vendor-specific or otherwise unrecognized submessage kind."
              ))?,
            };
          (decoded_submessage, sending_endpoint_infos)
        } else {
          Err(create_security_error_and_log!(
            "When transformation kind is GCM, decode_datawriter_submessage expects a SecureBody, \
             received {:?}",
            encoded_submessage.header.kind
          ))?
        }
      }
    };

    match decoded_submessage {
      SubmessageBody::Writer(writer_submessage) => {
        let matching_readers = SecurityResult::<Vec<_>>::from_iter(
          sending_endpoint_infos.iter().filter_map(
            |EndpointInfo {
               crypto_handle: remote_endpoint_crypto_handle,
               kind,
             }| match kind {
              EndpointKind::DataWriter => Some(
                self
                  .matched_local_endpoint
                  .get(remote_endpoint_crypto_handle)
                  .copied()
                  .ok_or_else(|| {
                    create_security_error_and_log!(
                      "The local reader matched to the remote writer crypto handle {} is missing.",
                      remote_endpoint_crypto_handle
                    )
                  }),
              ),
              _ => None,
            },
          ),
        )?;
        if matching_readers.is_empty() {
          // All remote writers failed the MAC check
          Ok(DecodeOutcome::ValidatingReceiverSpecificMACFailed)
        } else {
          Ok(DecodeOutcome::Success(DecodedSubmessage::Writer(
            writer_submessage,
            matching_readers,
          )))
        }
      }
      SubmessageBody::Reader(reader_submessage) => {
        let matching_writers = SecurityResult::<Vec<_>>::from_iter(
          sending_endpoint_infos.iter().filter_map(
            |EndpointInfo {
               crypto_handle: remote_endpoint_crypto_handle,
               kind,
             }| match kind {
              EndpointKind::DataReader => Some(
                self
                  .matched_local_endpoint
                  .get(remote_endpoint_crypto_handle)
                  .copied()
                  .ok_or_else(|| {
                    create_security_error_and_log!(
                      "The local writer matched to the remote reader crypto handle {} is missing.",
                      remote_endpoint_crypto_handle
                    )
                  }),
              ),
              _ => None,
            },
          ),
        )?;
        if matching_writers.is_empty() {
          // All remote readers failed the MAC check
          Ok(DecodeOutcome::ValidatingReceiverSpecificMACFailed)
        } else {
          Ok(DecodeOutcome::Success(DecodedSubmessage::Reader(
            reader_submessage,
            matching_writers,
          )))
        }
      }

      SubmessageBody::Interpreter(interpreter_submessage) => {
        debug!(
          "Interpreter submessage after successful submessage decryption. This is not in the \
           specification, but we accept for compatibility as we also accept unprotected \
           interpreter submessages."
        );
        Ok(DecodeOutcome::Success(DecodedSubmessage::Interpreter(
          interpreter_submessage,
        )))
      }
      SubmessageBody::Security(_) => Err(create_security_error_and_log!(
        "Security submessage after successful submessage decryption."
      )),
    }
  }

  fn decode_serialized_payload(
    &self,
    encoded_buffer: Vec<u8>,
    _inline_qos: ParameterList,
    _receiving_datareader_crypto_handle: DatareaderCryptoHandle,
    sending_datawriter_crypto_handle: DatawriterCryptoHandle,
  ) -> SecurityResult<Vec<u8>> {
    // According to DDS Security spec v1.1 Section
    // "9.5.3.3.4.4 Result from encode_serialized_payload"
    // the incoming data buffer is either
    //
    // CryptoHeader + SerializedPayload + CryptoFooter  (only signed)
    // or
    // CryptoHeader + CryptoContent + CryptoFooter
    //
    // We can detect which one it is from CryptoHeader contents.
    // splitting to the three parts has to be done by byte offset, because
    // SerializedPayload does not have a length marker, but both header and footer
    // have a fixed length. Footer is not allowed to have receiver specific MACs
    // here, which makes its size fixed.

    let head_len = BuiltinCryptoHeader::serialized_len();
    let foot_len = BuiltinCryptoFooter::minimal_serialized_len();

    // check length so that following split do not panic and subtract does not
    // underflow
    if encoded_buffer.len() < head_len + foot_len {
      return Err(security_error("Encoded payload smaller than minimum size"));
    }
    let (header_bytes, content_and_footer_bytes) = encoded_buffer.split_at(head_len);

    // Deserialize crypto header and footer

    // .read_from_buffer() does not need endianness, because BuiltinCryptoHeader
    // only contains byte-oriented data, which is insensitive to endianness.
    let crypto_header = CryptoHeader::read_from_buffer(header_bytes)?;

    let BuiltinCryptoHeader {
      transform_identifier:
        BuiltinCryptoTransformIdentifier {
          transformation_kind,
          transformation_key_id,
        },
      builtin_crypto_header_extra: BuiltinCryptoHeaderExtra(initialization_vector),
    } = crypto_header.try_into()?;

    // Get the payload decode key material
    let decode_key_material = self.session_decode_crypto_materials(
      sending_datawriter_crypto_handle,
      transformation_key_id,
      KeyMaterialScope::PayloadOnly,
      initialization_vector,
    )?;

    // Check that the transformation kind stays consistent
    if decode_key_material.transformation_kind != transformation_kind {
      return Err(create_security_error_and_log!(
        "Mismatched transformation kinds: the decoded CryptoHeader has {:?}, but the key material \
         associated with the sending datawriter {} has {:?}.",
        transformation_kind,
        sending_datawriter_crypto_handle,
        decode_key_material.transformation_kind
      ));
    }

    let decode_key = &decode_key_material.session_key;

    match transformation_kind {
      BuiltinCryptoTransformationKind::CRYPTO_TRANSFORMATION_KIND_NONE => {
        Err(create_security_error_and_log!(
          "Transformation kind NONE found in decode_serialized_payload. If the transformation \
           kind is NONE, this method should not have been called."
        ))
      }
      BuiltinCryptoTransformationKind::CRYPTO_TRANSFORMATION_KIND_AES128_GMAC
      | BuiltinCryptoTransformationKind::CRYPTO_TRANSFORMATION_KIND_AES256_GMAC => {
        // radar_ros patch 25: the signed SerializedPayload has no length of its own; try the splits that
        // leave 0-3 bytes of submessage padding after the footer
        let mut last_err = security_error("Encoded payload smaller than minimum size");
        for (content_bytes, footer_bytes) in payload_splits(content_and_footer_bytes, foot_len) {
          let result = BuiltinCryptoFooter::try_from(footer_bytes).and_then(
            |BuiltinCryptoFooter { common_mac, .. }| {
              validate_mac(decode_key, initialization_vector, content_bytes, common_mac)
            },
          );
          match result {
            // if validate_mac succeeds, then map result to content bytes
            Ok(()) => return Ok(Vec::from(content_bytes)),
            Err(e) => last_err = e,
          }
        }
        Err(last_err)
      }
      BuiltinCryptoTransformationKind::CRYPTO_TRANSFORMATION_KIND_AES128_GCM
      | BuiltinCryptoTransformationKind::CRYPTO_TRANSFORMATION_KIND_AES256_GCM => {
        // radar_ros patch 25: CryptoContent says its length; the footer follows it (any bytes after the
        // footer are the submessage's padding)
        let (content_bytes, footer_bytes) = gcm_split(content_and_footer_bytes, foot_len)?;
        let BuiltinCryptoFooter { common_mac, .. } = BuiltinCryptoFooter::try_from(footer_bytes)?;
        // The ciphertext is decrypted in the buffer it came in, moved to its start (RADAR patch 67: it was
        // copied out into a CryptoContent of its own): the CryptoContent is its 4-byte length, then it
        let ciphertext = head_len + 4..head_len + content_bytes.len();
        let mut buffer = encoded_buffer;
        buffer.truncate(ciphertext.end);
        buffer.drain(..ciphertext.start);
        decrypt(decode_key, initialization_vector, buffer, common_mac)
      }
    }
  }
}

// radar_ros patch 25: an encoded payload as it arrives may end with up to 3 bytes that are not its own. A
// DATA submessage that is not the last of its RTPS message is padded to a multiple of 4 bytes (the writer
// piggybacks a HEARTBEAT after it), and the receiver takes everything up to the next submessage as the
// payload. A plain CDR payload ignores them; an encoded one must find its footer after its content, not at
// the end of the buffer.

/// The (content, footer) splits of `content_and_footer` for a signed (GMAC) payload, the one without
/// padding first.
fn payload_splits(content_and_footer: &[u8], foot_len: usize) -> Vec<(&[u8], &[u8])> {
  (0..=3)
    .filter_map(|pad| {
      let end = content_and_footer.len().checked_sub(pad)?;
      let split = end.checked_sub(foot_len)?;
      Some((&content_and_footer[..split], &content_and_footer[split..end]))
    })
    .collect()
}

/// The (CryptoContent, footer) of an encrypted (GCM) payload: the content's big-endian length says where
/// the footer starts.
fn gcm_split(content_and_footer: &[u8], foot_len: usize) -> SecurityResult<(&[u8], &[u8])> {
  let too_short = || security_error("Encoded payload shorter than its CryptoContent says");
  let len_bytes: [u8; 4] = content_and_footer
    .get(..4)
    .and_then(|b| b.try_into().ok())
    .ok_or_else(too_short)?;
  let content_end = usize::try_from(u32::from_be_bytes(len_bytes))
    .ok()
    .and_then(|n| n.checked_add(4))
    .ok_or_else(too_short)?;
  let footer_end = content_end.checked_add(foot_len).ok_or_else(too_short)?;
  if footer_end > content_and_footer.len() || content_and_footer.len() - footer_end > 3 {
    return Err(too_short());
  }
  Ok((
    &content_and_footer[..content_end],
    &content_and_footer[content_end..footer_end],
  ))
}

#[cfg(test)]
mod padded_payload_tests {
  use super::{super::aes_gcm_gmac::encrypt, *};

  fn iv() -> BuiltinInitializationVector {
    BuiltinInitializationVector::new(SessionId::new([0, 0, 0, 1]), [7; 8])
  }

  /// An encoded payload of 5 bytes (`std_msgs/msg/Empty` with its encapsulation header) followed by the 3
  /// bytes of padding its DATA submessage gets when a HEARTBEAT follows it: the footer is found and the
  /// payload decrypts (it did not: the last 20 bytes were taken as the footer).
  #[test]
  fn an_encrypted_payload_followed_by_submessage_padding_is_split_at_its_footer() {
    let key = BuiltinKey::generate_random(KeyLength::AES128);
    let plain = [0u8, 1, 0, 0, 0];
    let (ciphertext, mac) = encrypt(&key, iv(), plain.to_vec()).unwrap();
    let content = CryptoContent { data: ciphertext }.write_to_vec().unwrap();
    let footer = Vec::<u8>::try_from(BuiltinCryptoFooter::only_common_mac(mac)).unwrap();
    let foot_len = BuiltinCryptoFooter::minimal_serialized_len();
    assert_eq!(footer.len(), foot_len);
    for pad in 0..=3 {
      let mut buf = [content.clone(), footer.clone()].concat();
      buf.extend(std::iter::repeat(0).take(pad));
      let (c, f) = gcm_split(&buf, foot_len).unwrap();
      let BuiltinCryptoFooter { common_mac, .. } = BuiltinCryptoFooter::try_from(f).unwrap();
      let data = CryptoContent::read_from_buffer(c).unwrap().data;
      assert_eq!(decrypt(&key, iv(), data, common_mac).unwrap(), plain, "padding {pad}");
    }
    // more than a submessage's padding, or less than the content says: refused
    let mut long = [content.clone(), footer.clone()].concat();
    long.extend([0; 4]);
    assert!(gcm_split(&long, foot_len).is_err());
    assert!(gcm_split(&content, foot_len).is_err());
  }

  /// The same for a signed payload: one of the splits that leave 0-3 bytes after the footer validates.
  #[test]
  fn a_signed_payload_followed_by_submessage_padding_validates() {
    let key = BuiltinKey::generate_random(KeyLength::AES128);
    let plain = [0u8, 1, 0, 0, 0];
    let mac = compute_mac(&key, iv(), &plain).unwrap();
    let footer = Vec::<u8>::try_from(BuiltinCryptoFooter::only_common_mac(mac)).unwrap();
    let foot_len = BuiltinCryptoFooter::minimal_serialized_len();
    for pad in 0..=3 {
      let mut buf = [plain.to_vec(), footer.clone()].concat();
      buf.extend(std::iter::repeat(0).take(pad));
      let ok = payload_splits(&buf, foot_len).into_iter().find(|(c, f)| {
        let BuiltinCryptoFooter { common_mac, .. } = BuiltinCryptoFooter::try_from(*f).unwrap();
        validate_mac(&key, iv(), c, common_mac).is_ok()
      });
      assert_eq!(ok.map(|(c, _)| c.to_vec()), Some(plain.to_vec()), "padding {pad}");
    }
  }
}

#[cfg(test)]
mod unregistered_sender_tests {
  use super::*;
  use crate::security::{
    access_control::ParticipantSecurityAttributes,
    authentication::types::{Challenge, SharedSecret, SharedSecretHandle},
  };

  /// A submessage from a participant that has no registered endpoints (a peer leaving, whose endpoints went
  /// first): no keys, not an error. Before patch 31 it was an error, logged at error level once per submessage
  /// (54 lines as the secured deliberative example ended).
  #[test]
  fn a_submessage_from_a_participant_without_registered_endpoints_has_no_keys() {
    let mut c = CryptographicBuiltin::new();
    let local = c
      .register_local_participant(1, 1, &[], ParticipantSecurityAttributes::empty())
      .unwrap();
    let secret = SharedSecretHandle {
      shared_secret: SharedSecret::from([7; 32]),
      challenge1: Challenge::from([1; 32]),
      challenge2: Challenge::from([2; 32]),
    };
    let remote = c
      .register_matched_remote_participant(local, 2, 2, secret)
      .unwrap();
    let key_id = CryptoTransformKeyId::from([1, 2, 3, 4]);
    let header = BuiltinCryptoHeader {
      transform_identifier: BuiltinCryptoTransformIdentifier {
        transformation_kind: BuiltinCryptoTransformationKind::CRYPTO_TRANSFORMATION_KIND_AES128_GCM,
        transformation_key_id: key_id,
      },
      builtin_crypto_header_extra: BuiltinCryptoHeaderExtra(BuiltinInitializationVector::new(
        SessionId::new([0, 0, 0, 1]),
        [7; 8],
      )),
    };
    let prefix = SecurePrefix {
      crypto_header: CryptoHeader::from(header),
    };
    let body = SecureBody {
      crypto_content: CryptoContent { data: vec![0; 16] },
    }
    .create_submessage(speedy::Endianness::LittleEndian)
    .unwrap();
    let postfix = SecurePostfix {
      crypto_footer: CryptoFooter::try_from(BuiltinCryptoFooter::only_common_mac([0; 16])).unwrap(),
    };
    match c.decode_submessage((prefix, body, postfix), local, remote) {
      Ok(DecodeOutcome::KeysNotFound(k)) => assert_eq!(k, key_id),
      Ok(_) => panic!("decoded without keys"),
      Err(e) => panic!("an error for a sender without registered endpoints: {e:?}"),
    }
  }
}

#[cfg(test)]
mod decode_key_index_tests {
  use std::collections::HashSet as StdHashSet;

  use super::*;
  use crate::{
    messages::submessages::{
      ack_nack::AckNack,
      heartbeat::Heartbeat,
      submessage_flag::{ACKNACK_Flags, HEARTBEAT_Flags},
    },
    security::{
      access_control::{
        access_control_builtin::types::BuiltinPluginEndpointSecurityAttributes,
        ParticipantSecurityAttributes,
      },
      authentication::types::{Challenge, SharedSecret, SharedSecretHandle},
    },
    structure::{
      guid::EntityId,
      sequence_number::{SequenceNumber, SequenceNumberSet},
    },
  };

  fn secret() -> SharedSecretHandle {
    SharedSecretHandle {
      shared_secret: SharedSecret::from([7; 32]),
      challenge1: Challenge::from([1; 32]),
      challenge2: Challenge::from([2; 32]),
    }
  }

  /// Submessages encrypted, as radar_ros's governance asks (metadata_protection_kind ENCRYPT), or with origin
  /// authentication too (ENCRYPT_WITH_ORIGIN_AUTHENTICATION: a receiver-specific MAC per addressed endpoint).
  fn encrypted(origin_authenticated: bool) -> EndpointSecurityAttributes {
    EndpointSecurityAttributes {
      is_submessage_protected: true,
      is_payload_protected: true,
      plugin_endpoint_attributes: BuiltinPluginEndpointSecurityAttributes {
        is_submessage_encrypted: true,
        is_submessage_origin_authenticated: origin_authenticated,
        is_payload_encrypted: true,
      }
      .into(),
      ..EndpointSecurityAttributes::empty()
    }
  }

  /// What `decode_submessage` searched before patch 65: every registered endpoint of every participant that
  /// has decode key materials, with its participant and the key id of its submessage key. The oracle the
  /// index must equal.
  fn scanned(
    c: &CryptographicBuiltin,
  ) -> StdHashSet<(ParticipantCryptoHandle, CryptoTransformKeyId, EndpointInfo)> {
    let mut all = StdHashSet::new();
    for (participant, endpoints) in &c.participant_to_endpoint_info {
      for info in endpoints {
        if let Some(m) = c.decode_key_materials.get(&info.crypto_handle) {
          let key_id = m.select(KeyMaterialScope::MessageOrSubmessage).sender_key_id;
          all.insert((*participant, key_id, *info));
        }
      }
    }
    all
  }

  fn indexed(
    c: &CryptographicBuiltin,
  ) -> StdHashSet<(ParticipantCryptoHandle, CryptoTransformKeyId, EndpointInfo)> {
    let mut all = StdHashSet::new();
    for ((participant, key_id), endpoints) in &c.decode_key_index {
      assert!(!endpoints.is_empty(), "an empty entry is left in the index");
      for info in endpoints {
        assert!(
          all.insert((*participant, *key_id, *info)),
          "{info:?} twice in the index"
        );
      }
    }
    assert_eq!(all.len(), c.decode_key_index_entry.len());
    all
  }

  fn heartbeat(count: i32) -> Submessage {
    Heartbeat {
      reader_id: EntityId::UNKNOWN,
      writer_id: EntityId::UNKNOWN,
      first_sn: SequenceNumber::new(1),
      last_sn: SequenceNumber::new(1),
      count,
    }
    .create_submessage(BitFlags::from_flag(HEARTBEAT_Flags::Endianness))
    .unwrap()
  }

  fn acknack(count: i32) -> Submessage {
    AckNack {
      reader_id: EntityId::UNKNOWN,
      writer_id: EntityId::UNKNOWN,
      reader_sn_state: SequenceNumberSet::new_empty(SequenceNumber::new(2)),
      count,
    }
    .create_submessage(BitFlags::from_flag(ACKNACK_Flags::Endianness))
  }

  fn describe(o: &DecodeOutcome<DecodedSubmessage>) -> &'static str {
    match o {
      DecodeOutcome::Success(DecodedSubmessage::Writer(..)) => "a writer submessage",
      DecodeOutcome::Success(DecodedSubmessage::Reader(..)) => "a reader submessage",
      DecodeOutcome::Success(_) => "another submessage",
      DecodeOutcome::KeysNotFound(_) => "no keys",
      _ => "a failed MAC check",
    }
  }

  fn as_received(encoded: EncodedSubmessage) -> (SecurePrefix, Submessage, SecurePostfix) {
    let EncodedSubmessage::Encoded(prefix, body, postfix) = encoded else {
      panic!("the submessage was not protected");
    };
    let SubmessageBody::Security(SecuritySubmessage::SecurePrefix(prefix, _)) = prefix.body else {
      panic!("no SecurePrefix first");
    };
    let SubmessageBody::Security(SecuritySubmessage::SecurePostfix(postfix, _)) = postfix.body else {
      panic!("no SecurePostfix last");
    };
    (prefix, body, postfix)
  }

  /// A sending participant `a` with many writers, a receiving `b` whose readers match them (two readers of `b`
  /// both match writer 0, so one key id stands for two of `b`'s remote writers). Through registration, key
  /// exchange and unregistration the index holds exactly what a scan of all endpoints finds, and a submessage
  /// of each writer decodes for exactly the readers matched with it, or finds no keys once they are gone.
  #[test]
  fn the_decode_key_index_equals_a_scan_and_decodes_for_the_matched_readers() {
    decodes_for_the_matched_endpoints(false);
  }

  /// The same with origin authentication: a reader's submessage addressed to one of the writers it matched is
  /// for that writer only (the others' receiver-specific keys are not derived, patch 65, and they do not pass).
  #[test]
  fn with_origin_authentication_a_submessage_is_for_the_endpoints_it_is_addressed_to() {
    decodes_for_the_matched_endpoints(true);
  }

  fn decodes_for_the_matched_endpoints(origin_authenticated: bool) {
    const WRITERS: usize = 12;
    let encrypted = || encrypted(origin_authenticated);
    let (mut a, mut b) = (CryptographicBuiltin::new(), CryptographicBuiltin::new());
    let pa = a
      .register_local_participant(1, 1, &[], ParticipantSecurityAttributes::empty())
      .unwrap();
    let pb = b
      .register_local_participant(2, 2, &[], ParticipantSecurityAttributes::empty())
      .unwrap();
    let pb_in_a = a
      .register_matched_remote_participant(pa, 2, 2, secret())
      .unwrap();
    let pa_in_b = b
      .register_matched_remote_participant(pb, 1, 1, secret())
      .unwrap();
    let readers = [
      b.register_local_datareader(pb, &[], encrypted()).unwrap(),
      b.register_local_datareader(pb, &[], encrypted()).unwrap(),
    ];
    assert_eq!(indexed(&b), scanned(&b));

    // writer i: its handle in a, the reader handles a has for it, and its handles in b (one per matched reader)
    let mut writers = Vec::new();
    for i in 0..WRITERS {
      let w = a.register_local_datawriter(pa, &[], encrypted()).unwrap();
      let matched: &[_] = if i == 0 { &readers } else { &readers[..1] };
      let (mut readers_in_a, mut in_b) = (Vec::new(), Vec::new());
      for &reader in matched {
        let r_in_a = a
          .register_matched_remote_datareader(w, pb_in_a, secret(), false)
          .unwrap();
        let w_in_b = b
          .register_matched_remote_datawriter(reader, pa_in_b, secret())
          .unwrap();
        assert_eq!(indexed(&b), scanned(&b), "writer {i} registered in b");
        let tokens = a.create_local_datawriter_crypto_tokens(w, r_in_a).unwrap();
        b.set_remote_datawriter_crypto_tokens(reader, w_in_b, tokens)
          .unwrap();
        assert_eq!(indexed(&b), scanned(&b), "writer {i}'s tokens set in b");
        let tokens = b.create_local_datareader_crypto_tokens(reader, w_in_b).unwrap();
        a.set_remote_datareader_crypto_tokens(w, r_in_a, tokens)
          .unwrap();
        assert_eq!(indexed(&a), scanned(&a), "writer {i}'s reader's tokens set in a");
        readers_in_a.push(r_in_a);
        in_b.push((w_in_b, reader));
      }
      writers.push((w, readers_in_a, in_b));
    }
    assert_eq!(scanned(&b).len(), WRITERS + 1);

    let decode = |b: &CryptographicBuiltin, i: usize, count: i32| {
      let (w, readers_in_a, _) = &writers[i];
      let encoded = a
        .encode_datawriter_submessage(heartbeat(count), *w, readers_in_a.clone())
        .unwrap();
      b.decode_submessage(as_received(encoded), pb, pa_in_b)
        .unwrap()
    };
    for (i, (_, _, in_b)) in writers.iter().enumerate() {
      match decode(&b, i, i as i32) {
        DecodeOutcome::Success(DecodedSubmessage::Writer(_, mut got)) => {
          let mut want: Vec<_> = in_b.iter().map(|(_, r)| *r).collect();
          got.sort_unstable();
          want.sort_unstable();
          assert_eq!(got, want, "writer {i}'s submessage is for its matched readers");
        }
        other => panic!("writer {i}'s submessage did not decode: {}", describe(&other)),
      }
    }

    // reader 0 is matched with every writer of a: a has a handle for it per writer, all under its one key id
    // (so one session key, patch 65's shared derivation), and its submessage is for all of them
    let reader_handles_in_b: Vec<_> = writers
      .iter()
      .flat_map(|(_, _, in_b)| in_b.iter())
      .filter(|(_, reader)| *reader == readers[0])
      .map(|(w_in_b, _)| *w_in_b)
      .collect();
    let encoded = b
      .encode_datareader_submessage(acknack(1), readers[0], reader_handles_in_b)
      .unwrap();
    match a.decode_submessage(as_received(encoded), pa, pb_in_a).unwrap() {
      DecodeOutcome::Success(DecodedSubmessage::Reader(_, mut got)) => {
        let mut want: Vec<_> = writers.iter().map(|(w, _, _)| *w).collect();
        got.sort_unstable();
        want.sort_unstable();
        assert_eq!(got, want, "reader 0's submessage is for every writer matched with it");
      }
      other => panic!("reader 0's submessage did not decode: {}", describe(&other)),
    }
    // addressed to writer 3 alone (as an ACKNACK is): with origin authentication, for writer 3 only
    let (w3_in_b, _) = writers[3].2[0];
    let encoded = b
      .encode_datareader_submessage(acknack(2), readers[0], vec![w3_in_b])
      .unwrap();
    match a.decode_submessage(as_received(encoded), pa, pb_in_a).unwrap() {
      DecodeOutcome::Success(DecodedSubmessage::Reader(_, mut got)) => {
        let mut want: Vec<_> = if origin_authenticated {
          vec![writers[3].0]
        } else {
          writers.iter().map(|(w, _, _)| *w).collect()
        };
        got.sort_unstable();
        want.sort_unstable();
        assert_eq!(got, want, "reader 0's submessage to writer 3");
      }
      other => panic!("reader 0's submessage to writer 3 did not decode: {}", describe(&other)),
    }

    // b forgets every other writer (and one of writer 0's two matches): their submessages find no keys
    let mut gone = Vec::new();
    for i in (0..WRITERS).step_by(2) {
      let (w_in_b, _) = writers[i].2[writers[i].2.len() - 1];
      b.unregister_datawriter(w_in_b).unwrap();
      assert_eq!(indexed(&b), scanned(&b), "writer {i} unregistered in b");
      if i != 0 {
        gone.push(i);
      }
    }
    for i in 0..WRITERS {
      let outcome = decode(&b, i, 100 + i as i32);
      match (gone.contains(&i), outcome) {
        (true, DecodeOutcome::KeysNotFound(_)) => {}
        (false, DecodeOutcome::Success(DecodedSubmessage::Writer(_, got))) => {
          assert_eq!(got, vec![readers[0]], "writer {i}");
        }
        (g, other) => panic!("writer {i} (unregistered: {g}): {}", describe(&other)),
      }
    }

    // b forgets a: nothing is left to decode with, and nothing in the index
    b.unregister_participant(pa_in_b).unwrap();
    assert_eq!(indexed(&b), scanned(&b));
    assert!(b.decode_key_index.is_empty() && b.decode_key_index_entry.is_empty());
    assert!(matches!(decode(&b, 1, 200), DecodeOutcome::KeysNotFound(_)));
  }
}

/// RADAR patch 67: messages and payloads are encoded into buffers written once (no submessage cloned, no
/// plaintext copied to be encrypted) and decrypted in the ciphertext's own buffer. The oracle is ring itself
/// (sealing and opening copies, as the code did before) and the serializers' own concatenation, with the key
/// derived again from the key material (not taken from the session key cache).
#[cfg(test)]
mod in_place_encoding_tests {
  use ring::aead::{Aad, LessSafeKey, Nonce, Tag, UnboundKey, AES_128_GCM, AES_256_GCM};

  use super::{super::aes_gcm_gmac::encrypt, *};
  use crate::{
    messages::{
      header::Header,
      submessages::{
        ack_nack::AckNack,
        heartbeat::Heartbeat,
        submessage_flag::{ACKNACK_Flags, HEARTBEAT_Flags},
      },
    },
    security::{
      access_control::{
        access_control_builtin::types::{
          BuiltinPluginEndpointSecurityAttributes, BuiltinPluginParticipantSecurityAttributes,
        },
        ParticipantSecurityAttributes,
      },
      authentication::types::{Challenge, SharedSecret, SharedSecretHandle},
    },
    structure::{
      guid::{EntityId, GuidPrefix},
      sequence_number::{SequenceNumber, SequenceNumberSet},
    },
  };

  fn secret() -> SharedSecretHandle {
    SharedSecretHandle {
      shared_secret: SharedSecret::from([9; 32]),
      challenge1: Challenge::from([3; 32]),
      challenge2: Challenge::from([4; 32]),
    }
  }

  fn participant(encrypted: bool) -> ParticipantSecurityAttributes {
    ParticipantSecurityAttributes {
      is_rtps_protected: true,
      plugin_participant_attributes: BuiltinPluginParticipantSecurityAttributes {
        is_rtps_encrypted: encrypted,
        is_discovery_encrypted: false,
        is_liveliness_encrypted: false,
        is_rtps_origin_authenticated: false,
        is_discovery_origin_authenticated: false,
        is_liveliness_origin_authenticated: false,
      }
      .into(),
      ..ParticipantSecurityAttributes::empty()
    }
  }

  fn payload_protected(encrypted: bool) -> EndpointSecurityAttributes {
    EndpointSecurityAttributes {
      is_payload_protected: true,
      plugin_endpoint_attributes: BuiltinPluginEndpointSecurityAttributes {
        is_submessage_encrypted: false,
        is_submessage_origin_authenticated: false,
        is_payload_encrypted: encrypted,
      }
      .into(),
      ..EndpointSecurityAttributes::empty()
    }
  }

  /// Participants `a` (sending) and `b`, matched both ways with their participant keys exchanged.
  fn pair(
    encrypted: bool,
  ) -> (
    CryptographicBuiltin,
    CryptographicBuiltin,
    [ParticipantCryptoHandle; 4],
  ) {
    let (mut a, mut b) = (CryptographicBuiltin::new(), CryptographicBuiltin::new());
    let pa = a
      .register_local_participant(1, 1, &[], participant(encrypted))
      .unwrap();
    let pb = b
      .register_local_participant(2, 2, &[], participant(encrypted))
      .unwrap();
    let pb_in_a = a
      .register_matched_remote_participant(pa, 2, 2, secret())
      .unwrap();
    let pa_in_b = b
      .register_matched_remote_participant(pb, 1, 1, secret())
      .unwrap();
    let tokens = a.create_local_participant_crypto_tokens(pa, pb_in_a).unwrap();
    b.set_remote_participant_crypto_tokens(pb, pa_in_b, tokens)
      .unwrap();
    let tokens = b.create_local_participant_crypto_tokens(pb, pa_in_b).unwrap();
    a.set_remote_participant_crypto_tokens(pa, pb_in_a, tokens)
      .unwrap();
    (a, b, [pa, pb, pb_in_a, pa_in_b])
  }

  /// The session key for `iv`, derived from `handle`'s key material (the derivation, not the cache), as ring's
  /// AES-GCM key.
  fn oracle_key(
    c: &CryptographicBuiltin,
    handle: CryptoHandle,
    scope: KeyMaterialScope,
    iv: BuiltinInitializationVector,
  ) -> LessSafeKey {
    let CommonEncodeKeyMaterials::Some(materials) =
      c.get_common_encode_key_materials(&handle).unwrap()
    else {
      panic!("no common key material")
    };
    let m = materials.select(scope);
    let key =
      CryptographicBuiltin::derive_session_key(ReceiverSpecific::No, &m.master_sender_key, &m.master_salt, iv);
    let algorithm = match key.key_length() {
      KeyLength::AES128 => &AES_128_GCM,
      KeyLength::AES256 => &AES_256_GCM,
      KeyLength::None => panic!("no key"),
    };
    LessSafeKey::new(UnboundKey::new(algorithm, key.as_bytes()).unwrap())
  }

  fn nonce(iv: BuiltinInitializationVector) -> Nonce {
    Nonce::assume_unique_for_key(iv.into())
  }

  fn submessages() -> Vec<Submessage> {
    vec![
      Heartbeat {
        reader_id: EntityId::UNKNOWN,
        writer_id: EntityId::UNKNOWN,
        first_sn: SequenceNumber::new(1),
        last_sn: SequenceNumber::new(5),
        count: 7,
      }
      .create_submessage(BitFlags::from_flag(HEARTBEAT_Flags::Endianness))
      .unwrap(),
      AckNack {
        reader_id: EntityId::UNKNOWN,
        writer_id: EntityId::UNKNOWN,
        reader_sn_state: SequenceNumberSet::new_empty(SequenceNumber::new(3)),
        count: 2,
      }
      .create_submessage(BitFlags::from_flag(ACKNACK_Flags::Endianness)),
    ]
  }

  /// The bytes of submessages as the generic (speedy) serializer writes them, one after another.
  fn serialized(submessages: &[Submessage]) -> Vec<u8> {
    submessages
      .iter()
      .flat_map(|s| {
        s.write_to_vec_with_ctx(speedy::Endianness::LittleEndian)
          .unwrap()
      })
      .collect()
  }

  fn security_submessage(s: &Submessage) -> &SecuritySubmessage {
    match &s.body {
      SubmessageBody::Security(m) => m,
      other => panic!("not a security submessage: {other:?}"),
    }
  }

  /// A message of a rtps-protected participant, encrypted (GCM) and signed (GMAC): the encoded message is the
  /// prefix, what the specification puts between (one SecureBody, or the InfoSource and the submessages as
  /// they were) and the postfix; ring opens the SecureBody with the derived key to the InfoSource and the
  /// submessages as the serializer writes them (or verifies the MAC over them); and the message, serialized
  /// and read back as it arrives, decodes in `b` to the same submessages.
  #[test]
  fn a_message_encoded_in_place_is_what_ring_and_the_serializer_give_and_decodes_back() {
    for encrypted in [true, false] {
      let (a, b, [pa, pb, pb_in_a, pa_in_b]) = pair(encrypted);
      let header = Header::new(GuidPrefix::new(&[1; 12]));
      let plain = submessages();
      let encoded = a
        .encode_rtps_message(
          Message {
            header,
            submessages: plain.clone(),
          },
          pa,
          vec![pb_in_a],
        )
        .unwrap();
      let info_source =
        InfoSource::from(header).create_submessage(BitFlags::from_endianness(speedy::Endianness::BigEndian));
      let expected_plaintext = serialized(&[vec![info_source.clone()], plain.clone()].concat());

      let n = encoded.submessages.len();
      let SecuritySubmessage::SecureRTPSPrefix(SecureRTPSPrefix { crypto_header }, _) =
        security_submessage(&encoded.submessages[0])
      else {
        panic!("no SecureRTPSPrefix first")
      };
      let SecuritySubmessage::SecureRTPSPostfix(SecureRTPSPostfix { crypto_footer }, _) =
        security_submessage(&encoded.submessages[n - 1])
      else {
        panic!("no SecureRTPSPostfix last")
      };
      let iv = BuiltinCryptoHeader::try_from(crypto_header.clone())
        .unwrap()
        .builtin_crypto_header_extra
        .0;
      let footer = BuiltinCryptoFooter::try_from(crypto_footer.clone()).unwrap();
      let key = oracle_key(&a, pa, KeyMaterialScope::MessageOrSubmessage, iv);
      if encrypted {
        assert_eq!(n, 3, "prefix, SecureBody, postfix");
        let SecuritySubmessage::SecureBody(SecureBody { crypto_content }, _) =
          security_submessage(&encoded.submessages[1])
        else {
          panic!("no SecureBody between")
        };
        let mut in_out = crypto_content.data.clone();
        let opened = key
          .open_in_place_separate_tag(
            nonce(iv),
            Aad::empty(),
            Tag::from(footer.common_mac),
            &mut in_out,
            0..,
          )
          .expect("ring opens the SecureBody with the derived key and the footer's MAC");
        assert_eq!(opened, &expected_plaintext[..]);
      } else {
        assert_eq!(n, plain.len() + 3, "prefix, InfoSource, the submessages, postfix");
        assert_eq!(serialized(&encoded.submessages[1..n - 1]), expected_plaintext);
        let mut tag = footer.common_mac;
        key
          .open_in_place(nonce(iv), Aad::from(&expected_plaintext[..]), &mut tag)
          .expect("the footer's MAC is ring's over the InfoSource and the submessages");
      }

      let bytes = encoded
        .write_to_vec_with_ctx(speedy::Endianness::LittleEndian)
        .unwrap();
      let received = Message::read_from_buffer(&Bytes::from(bytes)).unwrap();
      match b.decode_rtps_message(received, pb, pa_in_b).unwrap() {
        DecodeOutcome::Success(Message {
          submessages: decoded,
          ..
        }) => assert_eq!(serialized(&decoded), serialized(&plain), "encrypted {encrypted}"),
        _ => panic!("the message did not decode (encrypted {encrypted})"),
      }
    }
  }

  /// A payload encrypted (GCM) or signed (GMAC) into one buffer is, byte for byte, the CryptoHeader, the
  /// CryptoContent of ring's ciphertext (or the payload) and the footer as their serializers write them, for
  /// payloads of 0 to 40 bytes; and a matched reader of the peer decodes it (decrypted where it came in) to
  /// the payload, with 0-3 bytes of its DATA submessage's padding after it.
  #[test]
  fn a_payload_encoded_in_one_buffer_is_the_serializers_concatenation() {
    for encrypted in [true, false] {
      let (mut a, mut b, [pa, pb, pb_in_a, pa_in_b]) = pair(true);
      let w = a
        .register_local_datawriter(pa, &[], payload_protected(encrypted))
        .unwrap();
      let r = b
        .register_local_datareader(pb, &[], payload_protected(encrypted))
        .unwrap();
      let r_in_a = a
        .register_matched_remote_datareader(w, pb_in_a, secret(), false)
        .unwrap();
      let w_in_b = b
        .register_matched_remote_datawriter(r, pa_in_b, secret())
        .unwrap();
      let tokens = a.create_local_datawriter_crypto_tokens(w, r_in_a).unwrap();
      b.set_remote_datawriter_crypto_tokens(r, w_in_b, tokens)
        .unwrap();
      for len in 0..=40usize {
        let plain: Vec<u8> = (0..len as u8).map(|i| i.wrapping_mul(37)).collect();
        let (encoded, _) = a.encode_serialized_payload(plain.clone(), w).unwrap();
        let head_len = BuiltinCryptoHeader::serialized_len();
        let crypto_header = CryptoHeader::read_from_buffer(&encoded[..head_len]).unwrap();
        let iv = BuiltinCryptoHeader::try_from(crypto_header.clone())
          .unwrap()
          .builtin_crypto_header_extra
          .0;
        let key = oracle_key(&a, w, KeyMaterialScope::PayloadOnly, iv);
        let (content, tag) = if encrypted {
          let mut in_out = plain.clone();
          let tag = key
            .seal_in_place_separate_tag(nonce(iv), Aad::empty(), &mut in_out)
            .unwrap();
          (CryptoContent { data: in_out }.write_to_vec().unwrap(), tag)
        } else {
          let tag = key
            .seal_in_place_separate_tag(nonce(iv), Aad::from(&plain[..]), &mut [])
            .unwrap();
          (plain.clone(), tag)
        };
        let footer = Vec::<u8>::try_from(BuiltinCryptoFooter::only_common_mac(
          tag.as_ref().try_into().unwrap(),
        ))
        .unwrap();
        let expected = [crypto_header.write_to_vec().unwrap(), content, footer].concat();
        assert_eq!(encoded, expected, "encrypted {encrypted}, {len} bytes");
        for pad in 0..=3 {
          let mut received = encoded.clone();
          received.extend(std::iter::repeat_n(0, pad));
          let decoded = b
            .decode_serialized_payload(received, ParameterList::new(), r, w_in_b)
            .unwrap();
          assert_eq!(decoded, plain, "encrypted {encrypted}, {len} bytes, padding {pad}");
        }
      }
    }
  }

  /// Decryption in the ciphertext's buffer gives what ring's opening of a copy with the tag appended gives (the
  /// code before), and refuses a flipped bit in the ciphertext or the MAC as that does.
  #[test]
  fn decrypting_in_place_is_opening_a_copy_with_the_tag_appended() {
    let key = BuiltinKey::generate_random(KeyLength::AES256);
    let iv = BuiltinInitializationVector::new(SessionId::new([5, 6, 7, 8]), [1, 2, 3, 4, 5, 6, 7, 8]);
    let oracle = LessSafeKey::new(UnboundKey::new(&AES_256_GCM, key.as_bytes()).unwrap());
    let open_copy = |ciphertext: &[u8], mac: &BuiltinMAC| {
      let mut in_out = [ciphertext, mac].concat();
      oracle
        .open_in_place(nonce(iv), Aad::empty(), &mut in_out)
        .ok()
        .map(|p| p.to_vec())
    };
    for len in [0usize, 1, 15, 16, 17, 100] {
      let plain: Vec<u8> = (0..len).map(|i| (i * 11) as u8).collect();
      let (ciphertext, mac) = encrypt(&key, iv, plain.clone()).unwrap();
      assert_eq!(open_copy(&ciphertext, &mac), Some(plain.clone()));
      assert_eq!(decrypt(&key, iv, ciphertext.clone(), mac).unwrap(), plain);
      let mut bad_mac = mac;
      bad_mac[len % MAC_LENGTH] ^= 1;
      assert_eq!(open_copy(&ciphertext, &bad_mac), None);
      assert!(decrypt(&key, iv, ciphertext.clone(), bad_mac).is_err());
      if len > 0 {
        let mut bad = ciphertext.clone();
        bad[len / 2] ^= 0x80;
        assert_eq!(open_copy(&bad, &mac), None);
        assert!(decrypt(&key, iv, bad, mac).is_err());
      }
    }
  }

  /// A security submessage's header says the length its body writes (counted, patch 67; it was the length of
  /// the body written out to a new Vec), in both byte orders: SecureBody with 0-40 bytes of content, the
  /// prefixes, and the postfixes with 0-3 receiver-specific MACs.
  #[test]
  fn a_security_submessages_length_is_the_length_its_body_writes() {
    fn same<T: Writable<speedy::Endianness>>(
      body: &T,
      submessage: SecurityResult<Submessage>,
      what: &str,
    ) {
      let length = submessage.unwrap().header.content_length as usize;
      for e in [speedy::Endianness::LittleEndian, speedy::Endianness::BigEndian] {
        assert_eq!(length, body.write_to_vec_with_ctx(e).unwrap().len(), "{what}, {e:?}");
      }
    }
    for len in 0..=40u8 {
      let body = SecureBody {
        crypto_content: CryptoContent {
          data: (0..len).collect(),
        },
      };
      for e in [speedy::Endianness::LittleEndian, speedy::Endianness::BigEndian] {
        same(&body, body.clone().create_submessage(e), "SecureBody");
      }
    }
    let header = || {
      CryptoHeader::from(BuiltinCryptoHeader {
        transform_identifier: BuiltinCryptoTransformIdentifier {
          transformation_kind: BuiltinCryptoTransformationKind::CRYPTO_TRANSFORMATION_KIND_AES256_GCM,
          transformation_key_id: CryptoTransformKeyId::from([9, 8, 7, 6]),
        },
        builtin_crypto_header_extra: BuiltinInitializationVector::new(SessionId::new([1; 4]), [2; 8])
          .into(),
      })
    };
    let prefix = SecurePrefix {
      crypto_header: header(),
    };
    same(&prefix, prefix.clone().create_submessage(speedy::Endianness::BigEndian), "SecurePrefix");
    let rtps_prefix = SecureRTPSPrefix {
      crypto_header: header(),
    };
    same(&rtps_prefix, rtps_prefix.clone().create_submessage(speedy::Endianness::BigEndian), "SecureRTPSPrefix");
    for macs in 0..=3u8 {
      let footer = || {
        CryptoFooter::try_from(BuiltinCryptoFooter {
          common_mac: [macs; MAC_LENGTH],
          receiver_specific_macs: (0..macs)
            .map(|i| ReceiverSpecificMAC {
              receiver_mac_key_id: CryptoTransformKeyId::from([i; 4]),
              receiver_mac: [i; MAC_LENGTH],
            })
            .collect(),
        })
        .unwrap()
      };
      let postfix = SecurePostfix {
        crypto_footer: footer(),
      };
      same(&postfix, postfix.clone().create_submessage(speedy::Endianness::BigEndian), "SecurePostfix");
      let rtps_postfix = SecureRTPSPostfix {
        crypto_footer: footer(),
      };
      same(&rtps_postfix, rtps_postfix.clone().create_submessage(speedy::Endianness::BigEndian), "SecureRTPSPostfix");
    }
  }

  /// An initialization vector is its session id, then its suffix (what concatenating them gave).
  #[test]
  fn an_initialization_vector_is_its_session_id_then_its_suffix() {
    let iv = BuiltinInitializationVector::new(SessionId::new([1, 2, 3, 4]), [5, 6, 7, 8, 9, 10, 11, 12]);
    assert_eq!(<[u8; 12]>::from(iv), [1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12]);
    assert_eq!(iv.session_id().as_bytes(), &[1, 2, 3, 4]);
  }
}

use std::borrow::Cow;

use ring::aead::*;

use crate::{
  create_security_error_and_log,
  security::{SecurityError, SecurityResult},
};
use super::{
  builtin_key::*,
  types::{BuiltinInitializationVector, BuiltinMAC, MAC_LENGTH},
};

// Generate a key of the given length
pub(super) fn keygen(key_length: KeyLength) -> BuiltinKey {
  BuiltinKey::generate_random(key_length)
}

/// A key the AES-GCM operations below can use: a [`SessionKey`], set up once (RADAR patch 64), or a
/// [`BuiltinKey`], set up for the one operation.
///
/// By design of Secure RTPS, there is a unique initialization vector for each submessage, and each key is
/// used once with it, so the nonce is the initialization vector itself.
pub(super) trait AeadKey {
  fn aead(&self) -> SecurityResult<Cow<'_, LessSafeKey>>;
}

fn empty_key_error() -> SecurityError {
  create_security_error_and_log!("Attempted to call a cryptographic function with an empty key.")
}

impl AeadKey for BuiltinKey {
  fn aead(&self) -> SecurityResult<Cow<'_, LessSafeKey>> {
    self
      .aes_gcm_key()
      .map(Cow::Owned)
      .ok_or_else(empty_key_error)
  }
}

impl AeadKey for SessionKey {
  fn aead(&self) -> SecurityResult<Cow<'_, LessSafeKey>> {
    SessionKey::aead(self)
      .map(Cow::Borrowed)
      .ok_or_else(empty_key_error)
  }
}

fn nonce(iv: BuiltinInitializationVector) -> Nonce {
  Nonce::assume_unique_for_key(iv.into())
}

fn to_builtin_mac(tag: &Tag) -> BuiltinMAC {
  // This .unwrap() cannot fail, as both have fixed length
  tag.as_ref().try_into().unwrap()
}

// Section "9.5.3.3.4.2 Format of the CryptoContent Submessage Element" :
// "Note that the cipher operations have 16-byte block-size and add padding when
// needed. Therefore the secure data.length (“N”) will always be a multiple of
// 16.""
//
// So we do not have to worry about adding padding here.
// We DO have to assume the ciphertext may be longer than the plaintext.

// Computes the message authentication code (MAC) for the given data
pub(super) fn compute_mac(
  key: &impl AeadKey,
  initialization_vector: BuiltinInitializationVector,
  data: &[u8],
) -> SecurityResult<BuiltinMAC> {
  // 9.5 (.0)
  //
  //The AES-GMAC transformation is defined as the special case where the
  // plaintext “P” is empty (zero length). This transformation produces only an
  // AuthenticationTag (Message Authentication Code) on the AAD data:
  //
  //T = AES-GMAC(K, AAD, IV) = AES-GCM(K, “”, AAD, IV)

  let tag =
    key
      .aead()?
      .seal_in_place_separate_tag(nonce(initialization_vector), Aad::from(data), &mut [])?;

  Ok(to_builtin_mac(&tag))
}

// Authenticated encryption: computes the ciphertext and and a MAC for it
pub(super) fn encrypt(
  key: &impl AeadKey,
  initialization_vector: BuiltinInitializationVector,
  plaintext: &[u8],
) -> SecurityResult<(Vec<u8>, BuiltinMAC)> {
  // Compute the ciphertext
  // ring encrypts + tags (signs) in place, so we must create a buffer for that.
  let mut in_out_data = Vec::from(plaintext);

  let tag = key.aead()?.seal_in_place_separate_tag(
    nonce(initialization_vector),
    Aad::empty(),
    &mut in_out_data,
  )?;

  Ok((in_out_data, to_builtin_mac(&tag)))
}

// Validates the MAC
pub(super) fn validate_mac(
  key: &impl AeadKey,
  initialization_vector: BuiltinInitializationVector,
  data: &[u8],
  mac: BuiltinMAC,
) -> SecurityResult<()> {
  let mut in_out = Vec::with_capacity(MAC_LENGTH);
  in_out.extend_from_slice(&mac);

  // This will return `Err(..)` if verification fails
  let _plaintext =
    key
      .aead()?
      .open_in_place(nonce(initialization_vector), Aad::from(data), &mut in_out)?;
  // If we get here, the mac ("tag") was valid.
  Ok(())
}

// Authenticated decryption: validates the MAC and decrypts the ciphertext
pub(super) fn decrypt(
  key: &impl AeadKey,
  initialization_vector: BuiltinInitializationVector,
  ciphertext: &[u8],
  mac: BuiltinMAC,
) -> SecurityResult<Vec<u8>> {
  // TODO: round data.len() up to block size
  let mut in_out = Vec::with_capacity(ciphertext.len() + MAC_LENGTH);
  in_out.extend_from_slice(ciphertext.as_ref());
  in_out.extend_from_slice(mac.as_ref());

  // This will return `Err(..)` if verification fails
  let plaintext =
    key
      .aead()?
      .open_in_place(nonce(initialization_vector), Aad::empty(), &mut in_out)?;
  // If we get here, the mac ("tag") was valid.
  // and `plaintext` is actually a slice of `in_out`
  let plain_len = plaintext.len();
  in_out.truncate(plain_len);

  Ok(in_out)
}

use std::borrow::Cow;

use ring::aead::*;

use crate::{
  create_security_error_and_log,
  security::{SecurityError, SecurityResult},
};
use super::{
  builtin_key::*,
  types::{BuiltinInitializationVector, BuiltinMAC},
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

// Authenticated encryption: computes the ciphertext and and a MAC for it, in the plaintext's own buffer
// (RADAR patch 67: the plaintext, always a buffer its caller had just written, was copied into a new one
// first)
pub(super) fn encrypt(
  key: &impl AeadKey,
  initialization_vector: BuiltinInitializationVector,
  mut plaintext: Vec<u8>,
) -> SecurityResult<(Vec<u8>, BuiltinMAC)> {
  let mac = encrypt_in_place(key, initialization_vector, &mut plaintext)?;
  Ok((plaintext, mac))
}

// Authenticated encryption of `in_out` where it is: the ciphertext replaces the plaintext (AES-GCM's is as
// long), and the MAC is returned
pub(super) fn encrypt_in_place(
  key: &impl AeadKey,
  initialization_vector: BuiltinInitializationVector,
  in_out: &mut [u8],
) -> SecurityResult<BuiltinMAC> {
  let tag =
    key
      .aead()?
      .seal_in_place_separate_tag(nonce(initialization_vector), Aad::empty(), in_out)?;
  Ok(to_builtin_mac(&tag))
}

// Validates the MAC
pub(super) fn validate_mac(
  key: &impl AeadKey,
  initialization_vector: BuiltinInitializationVector,
  data: &[u8],
  mac: BuiltinMAC,
) -> SecurityResult<()> {
  // The tag is opened where it is, in a copy on the stack: not in a Vec of its own (RADAR patch 67)
  let mut in_out = mac;

  // This will return `Err(..)` if verification fails
  let _plaintext =
    key
      .aead()?
      .open_in_place(nonce(initialization_vector), Aad::from(data), &mut in_out)?;
  // If we get here, the mac ("tag") was valid.
  Ok(())
}

// Authenticated decryption: validates the MAC and decrypts the ciphertext, in the ciphertext's own buffer
// (RADAR patch 67: the ciphertext and the tag were copied into a new Vec first, and the caller copied the
// plaintext once more). On failure the buffer is gone with the error, as the submessage it came from.
pub(super) fn decrypt(
  key: &impl AeadKey,
  initialization_vector: BuiltinInitializationVector,
  mut ciphertext: Vec<u8>,
  mac: BuiltinMAC,
) -> SecurityResult<Vec<u8>> {
  // This will return `Err(..)` if verification fails
  let plain_len = key
    .aead()?
    .open_in_place_separate_tag(
      nonce(initialization_vector),
      Aad::empty(),
      Tag::from(mac),
      &mut ciphertext,
      0..,
    )?
    .len();
  // If we get here, the mac ("tag") was valid, and the plaintext is the start of the buffer (AES-GCM's
  // plaintext is as long as its ciphertext)
  ciphertext.truncate(plain_len);
  Ok(ciphertext)
}

//! Keystores and enclaves in the layout of `ros2 security` (sros2), made without a ROS installation.
//!
//! ```text
//! KEYSTORE/
//!   public/ca.cert.pem  identity_ca.cert.pem  permissions_ca.cert.pem      (one CA for both roles, as sros2)
//!   private/ca.key.pem  identity_ca.key.pem  permissions_ca.key.pem
//!   enclaves/governance.xml  governance.p7s
//!   enclaves/NAME/cert.pem key.pem identity_ca.cert.pem permissions_ca.cert.pem governance.p7s
//!                 permissions.xml permissions.p7s
//! ```
//!
//! Keys are ECDSA P-256 (sros2's `prime256v1`); documents are S/MIME signed by the CA (`openssl smime -sign
//! -text`, detached), which RustDDS and Fast DDS both verify. sros2 links the CA files; these are copies.

use std::path::{Path, PathBuf};

use openssl::{
    asn1::Asn1Time,
    bn::{BigNum, MsbOption},
    ec::{EcGroup, EcKey},
    hash::MessageDigest,
    nid::Nid,
    pkcs7::{Pkcs7, Pkcs7Flags},
    pkey::{PKey, Private},
    stack::Stack,
    x509::{extension::BasicConstraints, X509Name, X509},
};

use crate::error::{Error, Result};

/// Days a certificate made here is valid (sros2: 10 years).
const VALID_DAYS: u32 = 3650;

fn fail(what: impl std::fmt::Display, e: impl std::fmt::Display) -> Error {
    Error::Config {
        setting: "keystore",
        value: String::new(),
        reason: format!("{what}: {e}"),
    }
}

fn write(path: &Path, bytes: &[u8]) -> Result<()> {
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir)
            .map_err(|e| fail(format!("cannot create {}", dir.display()), e))?;
    }
    std::fs::write(path, bytes).map_err(|e| fail(format!("cannot write {}", path.display()), e))
}

fn read(path: &Path) -> Result<Vec<u8>> {
    std::fs::read(path).map_err(|e| {
        fail(
            format!(
                "cannot read {} (is this a keystore? make one with `radar security create_keystore DIR`)",
                path.display()
            ),
            e,
        )
    })
}

fn new_key() -> Result<PKey<Private>> {
    let group = EcGroup::from_curve_name(Nid::X9_62_PRIME256V1).map_err(|e| fail("P-256", e))?;
    let ec = EcKey::generate(&group).map_err(|e| fail("a key", e))?;
    PKey::from_ec_key(ec).map_err(|e| fail("a key", e))
}

fn name(cn: &str) -> Result<X509Name> {
    let mut n = X509Name::builder().map_err(|e| fail("a name", e))?;
    n.append_entry_by_nid(Nid::COMMONNAME, cn)
        .map_err(|e| fail(format!("the name CN={cn}"), e))?;
    Ok(n.build())
}

/// A certificate for `subject`'s `key`, signed by `issuer` (self-signed when `None`).
fn certificate(
    cn: &str,
    key: &PKey<Private>,
    issuer: Option<(&X509, &PKey<Private>)>,
) -> Result<X509> {
    let e = |x| fail(format!("the certificate of {cn}"), x);
    let mut b = X509::builder().map_err(e)?;
    b.set_version(2).map_err(e)?;
    let mut serial = BigNum::new().map_err(e)?;
    serial.rand(127, MsbOption::MAYBE_ZERO, false).map_err(e)?;
    let serial = serial.to_asn1_integer().map_err(e)?;
    b.set_serial_number(&serial).map_err(e)?;
    let subject = name(cn)?;
    b.set_subject_name(&subject).map_err(e)?;
    b.set_pubkey(key).map_err(e)?;
    let (from, to) = (
        Asn1Time::days_from_now(0).map_err(e)?,
        Asn1Time::days_from_now(VALID_DAYS).map_err(e)?,
    );
    b.set_not_before(&from).map_err(e)?;
    b.set_not_after(&to).map_err(e)?;
    match issuer {
        None => {
            b.set_issuer_name(&subject).map_err(e)?;
            b.append_extension(BasicConstraints::new().critical().ca().build().map_err(e)?)
                .map_err(e)?;
            b.sign(key, MessageDigest::sha256()).map_err(e)?;
        }
        Some((ca, ca_key)) => {
            b.set_issuer_name(ca.subject_name()).map_err(e)?;
            b.sign(ca_key, MessageDigest::sha256()).map_err(e)?;
        }
    }
    Ok(b.build())
}

/// `document` signed by the CA as S/MIME (what `openssl smime -sign -text` writes).
fn sign(document: &[u8], ca: &X509, ca_key: &PKey<Private>) -> Result<Vec<u8>> {
    let e = |x| fail("signing a document", x);
    let certs = Stack::new().map_err(e)?;
    let flags = Pkcs7Flags::TEXT | Pkcs7Flags::DETACHED;
    let p7 = Pkcs7::sign(ca, ca_key, &certs, document, flags).map_err(e)?;
    p7.to_smime(document, flags).map_err(e)
}

/// The keystore's CA: its certificate and key.
fn ca(keystore: &Path) -> Result<(X509, PKey<Private>)> {
    let cert = X509::from_pem(&read(&keystore.join("public/ca.cert.pem"))?)
        .map_err(|e| fail("the keystore's CA certificate", e))?;
    let key = PKey::private_key_from_pem(&read(&keystore.join("private/ca.key.pem"))?)
        .map_err(|e| fail("the keystore's CA key", e))?;
    Ok((cert, key))
}

/// The governance of a keystore: every domain, no unauthenticated participant, discovery, liveliness and
/// every topic's data encrypted, reading and writing under access control (sros2's default).
pub fn governance_xml() -> String {
    r#"<?xml version="1.0" encoding="UTF-8"?>
<dds xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance" xsi:noNamespaceSchemaLocation="http://www.omg.org/spec/DDS-Security/20170801/omg_shared_ca_governance.xsd">
  <domain_access_rules>
    <domain_rule>
      <domains>
        <id_range>
          <min>0</min>
          <max>232</max>
        </id_range>
      </domains>
      <allow_unauthenticated_participants>false</allow_unauthenticated_participants>
      <enable_join_access_control>true</enable_join_access_control>
      <discovery_protection_kind>ENCRYPT</discovery_protection_kind>
      <liveliness_protection_kind>ENCRYPT</liveliness_protection_kind>
      <rtps_protection_kind>SIGN</rtps_protection_kind>
      <topic_access_rules>
        <topic_rule>
          <topic_expression>*</topic_expression>
          <enable_discovery_protection>true</enable_discovery_protection>
          <enable_liveliness_protection>true</enable_liveliness_protection>
          <enable_read_access_control>true</enable_read_access_control>
          <enable_write_access_control>true</enable_write_access_control>
          <metadata_protection_kind>ENCRYPT</metadata_protection_kind>
          <data_protection_kind>ENCRYPT</data_protection_kind>
        </topic_rule>
      </topic_access_rules>
    </domain_rule>
  </domain_access_rules>
</dds>
"#
    .to_owned()
}

/// What an enclave may publish and subscribe: DDS topic expressions (`rt/dock/start`, `rt/*/state`, `rq/*`).
/// The deny lists are checked first (a topic they match is refused even if an allow list matches it too);
/// what no list matches is refused.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Grant {
    /// Topics it may write.
    pub publish: Vec<String>,
    /// Topics it may read.
    pub subscribe: Vec<String>,
    /// Topics it may not write.
    pub deny_publish: Vec<String>,
    /// Topics it may not read.
    pub deny_subscribe: Vec<String>,
}

impl Grant {
    /// Everything, as `ros2 security create_enclave` grants.
    pub fn all() -> Grant {
        Grant {
            publish: vec!["*".into()],
            subscribe: vec!["*".into()],
            ..Grant::default()
        }
    }
}

/// The permissions document of the enclave `enclave` (its certificate's subject is `CN=<enclave>`): a deny rule
/// (if `grant` denies anything), then an allow rule, then `DENY` for the rest, as sros2 writes them.
pub fn permissions_xml(enclave: &str, grant: &Grant) -> String {
    let topics = |ts: &[String]| {
        ts.iter()
            .map(|t| format!("            <topic>{}</topic>\n", xml_escape(t)))
            .collect::<String>()
    };
    let rule = |kind: &str, publish: &[String], subscribe: &[String]| {
        if publish.is_empty() && subscribe.is_empty() {
            return String::new();
        }
        let mut r = format!(
            "      <{kind}>\n        <domains>\n          <id_range>\n            <min>0</min>\n            \
             <max>232</max>\n          </id_range>\n        </domains>\n"
        );
        if !publish.is_empty() {
            r += &format!(
                "        <publish>\n          <topics>\n{}          </topics>\n        </publish>\n",
                topics(publish)
            );
        }
        if !subscribe.is_empty() {
            r += &format!(
                "        <subscribe>\n          <topics>\n{}          </topics>\n        </subscribe>\n",
                topics(subscribe)
            );
        }
        r + &format!("      </{kind}>\n")
    };
    format!(
        r#"<?xml version="1.0" encoding="UTF-8"?>
<dds xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance" xsi:noNamespaceSchemaLocation="http://www.omg.org/spec/DDS-Security/20170801/omg_shared_ca_permissions.xsd">
  <permissions>
    <grant name="{name}">
      <subject_name>CN={name}</subject_name>
      <validity>
        <not_before>2020-01-01T00:00:00</not_before>
        <not_after>2120-01-01T00:00:00</not_after>
      </validity>
{deny}{allow}      <default>DENY</default>
    </grant>
  </permissions>
</dds>
"#,
        name = xml_escape(enclave),
        deny = rule("deny_rule", &grant.deny_publish, &grant.deny_subscribe),
        allow = rule("allow_rule", &grant.publish, &grant.subscribe),
    )
}

fn xml_escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// `ros2 security create_keystore DIR`: a CA and the signed governance. Refuses a directory that already
/// holds a keystore (its CA would be lost).
pub fn create_keystore(dir: &Path) -> Result<()> {
    if dir.join("public/ca.cert.pem").exists() {
        return Err(fail(
            format!("{} already holds a keystore", dir.display()),
            "its CA is kept; make enclaves in it with `radar security create_enclave`",
        ));
    }
    let key = new_key()?;
    let cert = certificate("radar_ros keystore CA", &key, None)?;
    let cert_pem = cert.to_pem().map_err(|e| fail("the CA certificate", e))?;
    let key_pem = key
        .private_key_to_pem_pkcs8()
        .map_err(|e| fail("the CA key", e))?;
    for f in ["ca", "identity_ca", "permissions_ca"] {
        write(&dir.join(format!("public/{f}.cert.pem")), &cert_pem)?;
        write(&dir.join(format!("private/{f}.key.pem")), &key_pem)?;
    }
    let gov = governance_xml();
    write(&dir.join("enclaves/governance.xml"), gov.as_bytes())?;
    write(
        &dir.join("enclaves/governance.p7s"),
        &sign(gov.as_bytes(), &cert, &key)?,
    )?;
    Ok(())
}

/// `ros2 security create_enclave KEYSTORE NAME`: a key and certificate for `NAME`, permissions that `grant`
/// (`ros2`'s: everything), signed; the CA certificates and governance beside them. The enclave's directory.
pub fn create_enclave(keystore: &Path, enclave: &str, grant: &Grant) -> Result<PathBuf> {
    if !enclave.starts_with('/') {
        return Err(fail(
            format!("enclave {enclave:?}"),
            "an enclave name is absolute, like a fully qualified node name: /robot/planner",
        ));
    }
    let (ca, ca_key) = ca(keystore)?;
    let dir = super::enclave_dir(keystore, enclave);
    let key = new_key()?;
    let cert = certificate(enclave, &key, Some((&ca, &ca_key)))?;
    write(
        &dir.join("cert.pem"),
        &cert
            .to_pem()
            .map_err(|e| fail("the enclave's certificate", e))?,
    )?;
    write(
        &dir.join("key.pem"),
        &key.private_key_to_pem_pkcs8()
            .map_err(|e| fail("the enclave's key", e))?,
    )?;
    let ca_pem = ca.to_pem().map_err(|e| fail("the CA certificate", e))?;
    write(&dir.join("identity_ca.cert.pem"), &ca_pem)?;
    write(&dir.join("permissions_ca.cert.pem"), &ca_pem)?;
    write(
        &dir.join("governance.p7s"),
        &read(&keystore.join("enclaves/governance.p7s"))?,
    )?;
    let perms = permissions_xml(enclave, grant);
    write(&dir.join("permissions.xml"), perms.as_bytes())?;
    write(
        &dir.join("permissions.p7s"),
        &sign(perms.as_bytes(), &ca, &ca_key)?,
    )?;
    Ok(dir)
}

/// The enclave's permissions made again to grant `grant`, signed by the keystore's CA (what
/// [`super::policy::create_permission`] does with what a policy file grants the enclave). The enclave must exist
/// (`create_enclave`). The permissions document's path.
pub fn write_permission(keystore: &Path, enclave: &str, grant: &Grant) -> Result<PathBuf> {
    let dir = super::enclave_dir(keystore, enclave);
    if !dir.join("cert.pem").is_file() {
        return Err(fail(
            format!("no enclave {enclave} in {}", keystore.display()),
            format!(
                "make it first: `radar security create_enclave {} {enclave}`",
                keystore.display()
            ),
        ));
    }
    let (ca, ca_key) = ca(keystore)?;
    let perms = permissions_xml(enclave, grant);
    write(&dir.join("permissions.xml"), perms.as_bytes())?;
    write(
        &dir.join("permissions.p7s"),
        &sign(perms.as_bytes(), &ca, &ca_key)?,
    )?;
    Ok(dir.join("permissions.xml"))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A keystore and an enclave as `ros2 security` lays them out: the enclave's certificate is the CA's,
    /// for `CN=<enclave>`; governance and permissions verify against the CA as S/MIME; a changed byte does not.
    #[test]
    fn a_keystore_and_an_enclave_are_made_signed_and_verifiable() {
        let ks = std::env::temp_dir().join(format!("radar_keystore_test_{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&ks);
        create_keystore(&ks).unwrap();
        let again = create_keystore(&ks).unwrap_err().to_string();
        assert!(again.contains("already holds a keystore"), "{again}");
        let dir = create_enclave(&ks, "/robot/planner", &Grant::all()).unwrap();
        assert_eq!(dir, ks.join("enclaves/robot/planner"));
        for f in crate::security::ENCLAVE_FILES {
            assert!(dir.join(f).is_file(), "{f} is made");
        }
        let (ca, _) = ca(&ks).unwrap();
        let cert = X509::from_pem(&std::fs::read(dir.join("cert.pem")).unwrap()).unwrap();
        assert!(
            cert.verify(&ca.public_key().unwrap()).unwrap(),
            "signed by the CA"
        );
        let cn = cert
            .subject_name()
            .entries_by_nid(Nid::COMMONNAME)
            .next()
            .unwrap()
            .data()
            .to_string()
            .unwrap();
        assert_eq!(cn, "/robot/planner");
        let verify = |signed: &[u8]| {
            let (p7, content) = Pkcs7::from_smime(signed).unwrap();
            let mut store = openssl::x509::store::X509StoreBuilder::new().unwrap();
            store.add_cert(ca.clone()).unwrap();
            let store = store.build();
            let mut out = Vec::new();
            p7.verify(
                &Stack::new().unwrap(),
                &store,
                content.as_deref(),
                Some(&mut out),
                Pkcs7Flags::empty(),
            )
            .map(|_| out)
        };
        let perms = std::fs::read(dir.join("permissions.p7s")).unwrap();
        let text = String::from_utf8(verify(&perms).unwrap()).unwrap();
        assert!(
            text.contains("<subject_name>CN=/robot/planner</subject_name>"),
            "{text}"
        );
        let gov = std::fs::read(dir.join("governance.p7s")).unwrap();
        assert!(String::from_utf8(verify(&gov).unwrap())
            .unwrap()
            .contains("<allow_unauthenticated_participants>false"));
        // tampered: the grant widened after signing
        let tampered = String::from_utf8(perms)
            .unwrap()
            .replace("<max>232</max>", "<max>233</max>");
        assert!(
            verify(tampered.as_bytes()).is_err(),
            "a changed document does not verify"
        );
        let bad = create_enclave(&ks, "planner", &Grant::all())
            .unwrap_err()
            .to_string();
        assert!(bad.contains("absolute"), "{bad}");
        let none = create_enclave(&ks.join("nope"), "/x", &Grant::all())
            .unwrap_err()
            .to_string();
        assert!(none.contains("create_keystore"), "{none}");
        std::fs::remove_dir_all(&ks).unwrap();
    }
}

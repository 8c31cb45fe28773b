//! Proof that both ends of a link hold the same secret, without sending it: a challenge and
//! response in both directions, HMAC-SHA256 over fresh nonces from both sides.
//!
//! The master's `Hello` carries its nonce `Nm`, the worker's `Hello` its nonce `Nw` and, if the
//! worker has a secret, its proof `HMAC(secret, "strahl worker" ‖ version ‖ Nm ‖ Nw)`. A master
//! with the same secret checks it and answers with `Auth{HMAC(secret, "strahl master" ‖ version
//! ‖ Nm ‖ Nw)}`; the worker checks that before it takes a job. Each proof covers the other
//! side's fresh nonce, so a recorded handshake is worth nothing in the next session, and the
//! role label keeps one side's proof from being reflected back as the other's. Proofs are
//! compared in constant time (`hmac`'s `verify_slice`).

use hmac::{Hmac, Mac};
use sha2::Sha256;

/// A fresh random value each side contributes to a handshake.
pub type Nonce = [u8; 32];

/// An HMAC-SHA256 tag.
pub type Proof = [u8; 32];

/// The shortest secret a node accepts, in bytes.
pub const MIN_SECRET_LEN: usize = 16;

/// Who proves.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Role {
    /// The master (its `Auth`).
    Master,
    /// The worker (its `Hello`).
    Worker,
}

impl Role {
    fn label(self) -> &'static [u8] {
        match self {
            Role::Master => b"strahl master",
            Role::Worker => b"strahl worker",
        }
    }
}

fn mac(secret: &[u8], role: Role, master: &Nonce, worker: &Nonce) -> Hmac<Sha256> {
    // HMAC takes keys of any length; this cannot fail.
    let mut mac = <Hmac<Sha256> as Mac>::new_from_slice(secret)
        .unwrap_or_else(|_| unreachable!("HMAC accepts keys of any length"));
    mac.update(role.label());
    mac.update(&crate::wire::PROTOCOL_VERSION.to_le_bytes());
    mac.update(master);
    mac.update(worker);
    mac
}

/// The proof `role` gives for the nonces of one handshake.
pub fn prove(secret: &[u8], role: Role, master: &Nonce, worker: &Nonce) -> Proof {
    mac(secret, role, master, worker)
        .finalize()
        .into_bytes()
        .into()
}

/// Whether `proof` is `role`'s proof for these nonces under `secret` (constant time).
pub fn verify(secret: &[u8], role: Role, master: &Nonce, worker: &Nonce, proof: &Proof) -> bool {
    mac(secret, role, master, worker)
        .verify_slice(proof)
        .is_ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn proofs_depend_on_secret_role_and_both_nonces() {
        let (k, m, w) = (b"a secret of sixteen", [1u8; 32], [2u8; 32]);
        let p = prove(k, Role::Worker, &m, &w);
        assert!(verify(k, Role::Worker, &m, &w, &p));
        assert!(!verify(b"another secret!!!", Role::Worker, &m, &w, &p));
        assert!(!verify(k, Role::Master, &m, &w, &p), "a reflected proof");
        assert!(
            !verify(k, Role::Worker, &[3; 32], &w, &p),
            "a replayed proof"
        );
        assert!(!verify(k, Role::Worker, &m, &[3; 32], &p));
        let mut bad = p;
        bad[31] ^= 1;
        assert!(!verify(k, Role::Worker, &m, &w, &bad));
    }
}

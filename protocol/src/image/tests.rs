use proptest::prelude::*;

use super::*;

fn hex<const N: usize>(s: &str) -> [u8; N] {
    let v = hex_vec(s);
    v.try_into().unwrap_or_else(|v: Vec<u8>| panic!("{} hex bytes, expected {N}", v.len()))
}

fn hex_vec(s: &str) -> Vec<u8> {
    (0..s.len()).step_by(2).map(|i| u8::from_str_radix(&s[i..i + 2], 16).unwrap()).collect()
}

/// RFC 8032 section 7.1: secret key, public key, message, signature.
const RFC8032: [(&str, &str, &str, &str); 4] = [
    (
        "9d61b19deffd5a60ba844af492ec2cc44449c5697b326919703bac031cae7f60",
        "d75a980182b10ab7d54bfed3c964073a0ee172f3daa62325af021a68f707511a",
        "",
        "e5564300c360ac729086e2cc806e828a84877f1eb8e5d974d873e065224901555fb8821590a33bacc61e39701cf9b46bd25bf5f0595bbe24655141438e7a100b",
    ),
    (
        "4ccd089b28ff96da9db6c346ec114e0f5b8a319f35aba624da8cf6ed4fb8a6fb",
        "3d4017c3e843895a92b70aa74d1b7ebc9c982ccf2ec4968cc0cd55f12af4660c",
        "72",
        "92a009a9f0d4cab8720e820b5f642540a2b27b5416503f8fb3762223ebdb69da085ac1e43e15996e458f3613d0f11d8c387b2eaeb4302aeeb00d291612bb0c00",
    ),
    (
        "c5aa8df43f9f837bedb7442f31dcb7b166d38535076f094b85ce3a2e0b4458f7",
        "fc51cd8e6218a1a38da47ed00230f0580816ed13ba3303ac5deb911548908025",
        "af82",
        "6291d657deec24024827e69c3abe01a30ce548a284743a445e3680d7db5ac3ac18ff9b538d16f290ae67f760984dc6594a7c15e9716ed28dc027beceea1ec40a",
    ),
    (
        // TEST SHA(abc): the message is SHA-512("abc").
        "833fe62409237b9d62ec77587520911e9a759cec1d19755b7da901b96dca3d42",
        "ec172b93ad5e563bf4932c70e1245034c35467ef2efd4d64ebf819683467e2bf",
        "ddaf35a193617abacc417349ae20413112e6fa4e89a97ea20a9eeee64b55d39a2192992a274fc1a836ba3c23a3feebbd454d4423643ce80e2a9ac94fa54ca49f",
        "dc2a4459e7369633a52b1bf277839a00201009a3efbf3ecb69bea2186c26b58909351fc9ac90b3ecfdfbc7c66431e0303dca179c138ac17ad9bef1177331a704",
    ),
];

/// The check a cell runs on a header, here on the RFC's messages.
fn cell_verifies(key: &[u8; 32], message: &[u8], signature: &[u8; 64]) -> bool {
    signature_valid(key, message, signature).is_ok()
}

/// A key pair from a 32-byte secret seed.
fn key_pair(seed: [u8; 32]) -> salty::Keypair {
    salty::Keypair::from(&seed)
}

fn public(seed: &[u8; 32]) -> [u8; 32] {
    key_pair(*seed).public.to_bytes()
}

/// `s + L` for a little-endian scalar below 2^253: the same point, a
/// different signature; RFC 8032 requires it refused.
fn plus_order(signature: &[u8; 64]) -> [u8; 64] {
    let mut out = *signature;
    let mut carry = 0u16;
    for i in 0..32 {
        let sum = u16::from(signature[32 + i]) + u16::from(ORDER[i]) + carry;
        out[32 + i] = sum as u8;
        carry = sum >> 8;
    }
    out
}

#[test]
fn rfc8032_vectors_verify_and_every_changed_bit_is_refused() {
    for (secret, public, message, signature) in RFC8032 {
        let pair = key_pair(hex(secret));
        let (public, message, signature): ([u8; 32], _, [u8; 64]) = (hex(public), hex_vec(message), hex(signature));
        assert_eq!(pair.public.to_bytes(), public, "public key derived from the RFC's secret");
        assert_eq!(pair.sign(&message).to_bytes(), signature, "signature computed as the RFC's");
        assert!(cell_verifies(&public, &message, &signature));
        assert!(!cell_verifies(&public, &message, &plus_order(&signature)), "S + L is refused");
        for bit in 0..signature.len() * 8 {
            let mut bad = signature;
            bad[bit / 8] ^= 1 << (bit % 8);
            assert!(!cell_verifies(&public, &message, &bad), "signature bit {bit} flipped");
        }
        for bit in 0..message.len() * 8 {
            let mut bad = message.clone();
            bad[bit / 8] ^= 1 << (bit % 8);
            assert!(!cell_verifies(&public, &bad, &signature), "message bit {bit} flipped");
        }
        let mut longer = message.clone();
        longer.push(0);
        assert!(!cell_verifies(&public, &longer, &signature));
    }
}

/// The secret seed of the tests' update key.
fn test_key() -> [u8; 32] {
    [7; 32]
}

/// An image signed with the secret `seed`.
fn signed(board: Board, version: u32, body: &[u8], seed: &[u8; 32]) -> Vec<u8> {
    sign(body, board, version, seed).unwrap()
}

const MAX: u32 = 4096;

#[test]
fn a_signed_image_verifies_and_its_header_round_trips() {
    let pair = test_key();
    let body: Vec<u8> = (0..1000u32).map(|i| (i * 7) as u8).collect();
    let image = signed(Board::Mps2An386, 42, &body, &pair);
    let header = verify(&image, Board::Mps2An386, MAX, &public(&pair)).unwrap();
    assert_eq!((header.version, header.body_len), (42, 1000));
    assert_eq!(ImageHeader::parse(&header.to_bytes()), Ok(header));
}

#[test]
fn refusals_are_typed() {
    let pair = test_key();
    let body = [1u8; 300];
    let image = signed(Board::Mps2An386, 3, &body, &pair);
    let board = Board::Mps2An386;
    assert_eq!(
        verify(&image, Board::Stm32f405, MAX, &public(&pair)),
        Err(ImageError::WrongBoard { expected: Board::Stm32f405, found: board })
    );
    assert_eq!(verify(&image, board, 299, &public(&pair)), Err(ImageError::TooLong { len: 300, max: 299 }));
    assert_eq!(
        verify(&image[..image.len() - 1], board, MAX, &public(&pair)),
        Err(ImageError::LengthMismatch { expected: 300, found: 299 })
    );
    assert_eq!(verify(&image[..50], board, MAX, &public(&pair)), Err(ImageError::TooShort(50)));
    let other = [8; 32];
    assert_eq!(verify(&image, board, MAX, &public(&other)), Err(ImageError::BadSignature));
    let mut corrupt = image.clone();
    corrupt[HEADER_LEN + 10] ^= 0x40;
    assert_eq!(verify(&corrupt, board, MAX, &public(&pair)), Err(ImageError::BadDigest));
    // A body changed with its digest fixed up fails on the signature.
    let mut forged = corrupt.clone();
    let digest: [u8; 32] = Sha256::digest(&corrupt[HEADER_LEN..]).into();
    forged[16..48].copy_from_slice(&digest);
    assert_eq!(verify(&forged, board, MAX, &public(&pair)), Err(ImageError::BadSignature));
    // So does a version raised without the key.
    let mut newer = image.clone();
    newer[8] = 4;
    assert_eq!(verify(&newer, board, MAX, &public(&pair)), Err(ImageError::BadSignature));
    let mut reserved = image.clone();
    reserved[50] = 1;
    assert_eq!(verify(&reserved, board, MAX, &public(&pair)), Err(ImageError::ReservedNotZero));
    let mut unknown = image.clone();
    unknown[5] = 9;
    assert_eq!(verify(&unknown, board, MAX, &public(&pair)), Err(ImageError::UnknownBoard(9)));
    let mut format = image.clone();
    format[4] = 2;
    assert_eq!(verify(&format, board, MAX, &public(&pair)), Err(ImageError::UnknownFormat(2)));
    assert_eq!(verify(&image[1..], board, MAX, &public(&pair)), Err(ImageError::BadMagic));
}

#[test]
fn a_verifier_refuses_more_body_than_the_header_says() {
    let pair = test_key();
    let image = signed(Board::Stm32f405, 1, &[5; 10], &pair);
    let header = ImageHeader::parse(&image).unwrap();
    let mut v = Verifier::new(&header, Board::Stm32f405, MAX, &public(&pair)).unwrap();
    v.absorb(&[5; 6]).unwrap();
    assert_eq!(v.absorb(&[5; 5]), Err(ImageError::LengthMismatch { expected: 10, found: 11 }));
    v.absorb(&[5; 4]).unwrap();
    assert_eq!(v.finish().map(|h| h.version), Ok(1));
}

#[test]
fn board_names_round_trip() {
    for b in Board::ALL {
        assert_eq!(Board::from_name(b.name()), Some(b));
        assert_eq!(Board::from_u8(b as u8), Some(b));
    }
    assert_eq!(Board::from_name("esp32"), None);
}

proptest! {
    #[test]
    fn any_bytes_give_a_header_or_a_typed_error(
        mut bytes in proptest::collection::vec(any::<u8>(), 0..200),
        prefix in 0usize..7,
    ) {
        // Often the start of a real header, so the later checks are reached.
        let start = [b'S', b'K', b'F', b'W', FORMAT, Board::Mps2An386 as u8];
        let n = prefix.min(bytes.len());
        bytes[..n].copy_from_slice(&start[..n]);
        if let Ok(h) = ImageHeader::parse(&bytes) {
            prop_assert_eq!(&h.to_bytes()[..], &bytes[..HEADER_LEN]);
        }
        let key = test_key();
        prop_assert!(verify(&bytes, Board::Mps2An386, MAX, &public(&key)).is_err());
    }

    #[test]
    fn any_valid_header_prefix_with_any_body_is_checked_without_panic(
        body in proptest::collection::vec(any::<u8>(), 0..300),
        len in 0u32..400,
        flip in any::<(usize, u8)>(),
    ) {
        let key = test_key();
        let mut image = signed(Board::Mps2An386, 9, &body, &key);
        image[12..16].copy_from_slice(&len.to_le_bytes());
        let at = flip.0 % image.len();
        image[at] ^= flip.1;
        let result = verify(&image, Board::Mps2An386, MAX, &public(&key));
        // Only the untouched image of the stated length can pass.
        prop_assert_eq!(result.is_ok(), flip.1 == 0 && len as usize == body.len());
    }

    #[test]
    fn chunking_does_not_change_the_verdict(body in proptest::collection::vec(any::<u8>(), 0..600), step in 1usize..97) {
        let key = test_key();
        let image = signed(Board::Mps2An386, 1, &body, &key);
        let header = ImageHeader::parse(&image).unwrap();
        let mut v = Verifier::new(&header, Board::Mps2An386, MAX, &public(&key)).unwrap();
        for chunk in image[HEADER_LEN..].chunks(step) {
            v.absorb(chunk).unwrap();
        }
        prop_assert_eq!(v.finish(), Ok(header));
    }
}

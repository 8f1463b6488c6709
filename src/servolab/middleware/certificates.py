"""A fleet's certificates for Zenoh's TLS and mutual TLS: one certificate authority, and a
certificate with its private key for the router and for each client, named by the common name
the router's access control knows it by (:mod:`.fleet_security`).

Zenoh's manual ("TLS authentication") makes them with minica, a Go program; this module makes
the same files with :mod:`cryptography` (pyca, the library every Python TLS tool stands on),
so that a lab with only pip has them too:

* ``ca.pem`` and ``ca-key.pem``: the authority, self-signed, which signs the others and which
  every member trusts (Zenoh's ``root_ca_certificate``);
* ``NAME.pem`` and ``NAME-key.pem``: a certificate whose subject's common name is ``NAME``
  (what Zenoh's ``cert_common_names`` matches). A router's names the hosts and addresses it
  is reached at (subject alternative names: rustls, which Zenoh's TLS is, checks the name a
  client connects to against them, never against the common name) and may serve; a member's
  names none and may only be shown by a client, so no member can pose as the router.

Keys are ECDSA on P-256 (rustls takes it; smaller and faster than RSA 2048), PKCS#8 PEM, and
private keys are written readable by their owner only. An existing file is never overwritten:
the authority is reused when it exists (a new member joins the same fleet), a member's files
are refused.
"""

from __future__ import annotations

import datetime
import ipaddress
import os
import re
from dataclasses import dataclass
from pathlib import Path

from cryptography import x509
from cryptography.hazmat.primitives import hashes, serialization
from cryptography.hazmat.primitives.asymmetric import ec
from cryptography.x509.oid import ExtendedKeyUsageOID, NameOID

from ..errors import ServolabError

#: The authority's files in a certificates folder.
CA_CERTIFICATE, CA_KEY = "ca.pem", "ca-key.pem"
#: What a member's certificate is valid for unless told: where the fleet's tests and a single
#: machine reach it.
DEFAULT_HOSTS = ("localhost", "127.0.0.1")
#: Days a certificate is valid for unless told: a year, a lab's term.
DEFAULT_DAYS = 365
_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.-]{0,63}")


class CertificateError(ServolabError, ValueError):
    """A name, host or folder the certificates cannot be made with."""


@dataclass(frozen=True)
class Issued:
    """A member's certificate and private key files."""

    certificate: Path
    private_key: Path


def check_name(name: str) -> str:
    """A member's name: a common name and a file name at once (letters, digits, ``_.-``)."""
    if not _NAME.fullmatch(name):
        raise CertificateError(f"certificate name {name!r} is not 1 to 64 letters, digits, "
                               "'_', '.' or '-' starting with a letter or digit")
    return name


def _alternative_name(host: str) -> x509.GeneralName:
    try:
        return x509.IPAddress(ipaddress.ip_address(host))
    except ValueError:
        pass
    if not re.fullmatch(r"[A-Za-z0-9*]([A-Za-z0-9.-]{0,252})", host):
        raise CertificateError(f"host {host!r} is neither an IP address nor a DNS name")
    return x509.DNSName(host)


def _write_private(path: Path, key: ec.EllipticCurvePrivateKey) -> None:
    data = key.private_bytes(serialization.Encoding.PEM, serialization.PrivateFormat.PKCS8,
                             serialization.NoEncryption())
    descriptor = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
    with os.fdopen(descriptor, "wb") as file:
        file.write(data)


def _write_certificate(path: Path, certificate: x509.Certificate) -> None:
    with open(path, "xb") as file:
        file.write(certificate.public_bytes(serialization.Encoding.PEM))


def _refuse_existing(*paths: Path) -> None:
    for path in paths:
        if path.exists():
            raise CertificateError(f"{path} exists: servolab never overwrites a key or "
                                   "certificate (delete it to make a new one)")


def _validity(days: int) -> tuple[datetime.datetime, datetime.datetime]:
    if days < 1:
        raise CertificateError(f"days {days}: a certificate must be valid for 1 day or more")
    now = datetime.datetime.now(datetime.UTC)
    return now - datetime.timedelta(minutes=5), now + datetime.timedelta(days=days)


def authority(folder: Path, days: int = 10 * DEFAULT_DAYS) -> tuple[x509.Certificate,
                                                                    ec.EllipticCurvePrivateKey]:
    """The fleet's authority in ``folder``: read when ``ca.pem`` is there, else made (and the
    folder with it)."""
    cert_path, key_path = folder / CA_CERTIFICATE, folder / CA_KEY
    if cert_path.exists() or key_path.exists():
        try:
            certificate = x509.load_pem_x509_certificate(cert_path.read_bytes())
            key = serialization.load_pem_private_key(key_path.read_bytes(), password=None)
        except (OSError, ValueError) as exc:
            raise CertificateError(f"{folder}: cannot read the authority ({CA_CERTIFICATE}, "
                                   f"{CA_KEY}): {exc}") from None
        if not isinstance(key, ec.EllipticCurvePrivateKey):
            raise CertificateError(f"{key_path}: not an ECDSA key (made elsewhere? use "
                                   "another folder)")
        return certificate, key
    folder.mkdir(parents=True, exist_ok=True)
    key = ec.generate_private_key(ec.SECP256R1())
    name = x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, f"servolab fleet CA {folder.name}")])
    start, end = _validity(days)
    certificate = (x509.CertificateBuilder().subject_name(name).issuer_name(name)
                   .public_key(key.public_key()).serial_number(x509.random_serial_number())
                   .not_valid_before(start).not_valid_after(end)
                   .add_extension(x509.BasicConstraints(ca=True, path_length=0), critical=True)
                   .add_extension(x509.KeyUsage(
                       digital_signature=True, key_cert_sign=True, crl_sign=True,
                       content_commitment=False, key_encipherment=False,
                       data_encipherment=False, key_agreement=False, encipher_only=False,
                       decipher_only=False), critical=True)
                   .add_extension(x509.SubjectKeyIdentifier.from_public_key(key.public_key()),
                                  critical=False)
                   .sign(key, hashes.SHA256()))
    _write_private(key_path, key)
    _write_certificate(cert_path, certificate)
    return certificate, key


def issue(folder: Path, name: str, hosts: tuple[str, ...] = DEFAULT_HOSTS,
          days: int = DEFAULT_DAYS, *, router: bool = False) -> Issued:
    """Make ``NAME.pem`` and ``NAME-key.pem`` in ``folder``, signed by its authority (made
    first when the folder has none). A ``router``'s is for the ``hosts`` it is reached at and
    may serve TLS; a member's may only be shown by a client (no host names, client use
    only), so that no member can pose as the router to the others."""
    check_name(name)
    alternative = [_alternative_name(h) for h in hosts] if router else []
    if router and not alternative:
        raise CertificateError(f"{name}: give at least one host the router is reached at")
    out = Issued(folder / f"{name}.pem", folder / f"{name}-key.pem")
    _refuse_existing(out.certificate, out.private_key)
    ca_certificate, ca_key = authority(folder)
    key = ec.generate_private_key(ec.SECP256R1())
    start, end = _validity(days)
    builder = (x509.CertificateBuilder()
               .subject_name(x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, name)]))
                   .issuer_name(ca_certificate.subject)
                   .public_key(key.public_key()).serial_number(x509.random_serial_number())
                   .not_valid_before(start).not_valid_after(end)
                   .add_extension(x509.BasicConstraints(ca=False, path_length=None),
                                  critical=True)
                   .add_extension(x509.ExtendedKeyUsage(
                       [ExtendedKeyUsageOID.SERVER_AUTH, ExtendedKeyUsageOID.CLIENT_AUTH]
                       if router else [ExtendedKeyUsageOID.CLIENT_AUTH]), critical=False)
                   .add_extension(x509.AuthorityKeyIdentifier.from_issuer_public_key(
                       ca_key.public_key()), critical=False))
    if alternative:
        builder = builder.add_extension(x509.SubjectAlternativeName(alternative),
                                        critical=False)
    certificate = builder.sign(ca_key, hashes.SHA256())
    _write_private(out.private_key, key)
    _write_certificate(out.certificate, certificate)
    return out

#!/bin/sh
# The fleet's certificates (docs/fleet-deployment.md): a CA of its own, made once, and a
# server certificate for the broker signed by it, for the names robots connect to.
#   usage: sh make-certs.sh FOLDER HOSTNAME [IP ...]
# FOLDER keeps ca.key: make them on an administrator's machine, not on the broker, and
# copy only ca.crt (to robots and master controls) and server.crt, server.key (to the
# broker). Run again with the same FOLDER to renew the server certificate: the CA stays.
set -eu
folder=$1 host=$2
shift 2
# Robots check the broker's name against subjectAltName only (the CN is ignored): every
# name or address they are given in mqtts://HOST must be listed here.
names="DNS:$host"
for ip in "$@"; do names="$names,IP:$ip"; done
mkdir -p "$folder"
cd "$folder"
# Private keys are written owner-only from the start, never readable for a moment.
umask 077
# P-256 keys: as strong as RSA 3072 for TLS, made in milliseconds, and accepted by every
# OpenSSL that Mosquitto and Python are built on.
if [ ! -f ca.key ]; then
    # Ten years: the CA is what every robot trusts, and replacing it means visiting them.
    openssl req -x509 -new -newkey ec -pkeyopt ec_paramgen_curve:P-256 -nodes \
        -keyout ca.key -out ca.crt -days 3650 -subj "/CN=Giraff fleet CA" \
        -addext "basicConstraints=critical,CA:TRUE,pathlen:0" \
        -addext "keyUsage=critical,keyCertSign,cRLSign" 2>/dev/null
fi
openssl req -new -newkey ec -pkeyopt ec_paramgen_curve:P-256 -nodes \
    -keyout server.key -out server.csr -subj "/CN=$host" 2>/dev/null
# The extensions a strict verifier (Python's ssl on 3.13, VERIFY_X509_STRICT) asks of
# a server certificate: its names, not a CA, a server's key use, and key identifiers.
cat > server.ext <<END
subjectAltName = $names
basicConstraints = critical, CA:FALSE
keyUsage = critical, digitalSignature
extendedKeyUsage = serverAuth
subjectKeyIdentifier = hash
authorityKeyIdentifier = keyid:always
END
# 825 days (about two years): renewed without touching a robot, since they trust the CA.
openssl x509 -req -in server.csr -CA ca.crt -CAkey ca.key -CAcreateserial \
    -out server.crt -days 825 -extfile server.ext 2>/dev/null
rm server.csr server.ext
# Certificates are public; keys stay owner-only.
chmod 644 ca.crt server.crt

#!/bin/sh
# Makes a private certificate authority and one certificate per orsa process (robot, executive,
# teleop), for zenoh's TLS links (docs/security.md).
#
#   sh make-certs.sh DIR ROBOT_DNS_NAME ROBOT_IP
#   sh make-certs.sh /etc/orsa/tls robot.local 192.168.1.20
#
# DIR gets ca.pem (give it to every process), ca.key (keep it offline: whoever has it can make
# certificates your processes trust) and NAME.pem / NAME.key for each process (give each
# process only its own). The robot's certificate names ROBOT_DNS_NAME, ROBOT_IP, localhost and
# 127.0.0.1, so `--connect tls/ROBOT_DNS_NAME:7448` and `--connect tls/ROBOT_IP:7448` both pass
# the name check. Every certificate may serve both ends of a link (serverAuth and clientAuth),
# for mutual TLS.
set -eu
dir=${1:?usage: make-certs.sh DIR ROBOT_DNS_NAME ROBOT_IP}
robot_dns=${2:-robot.local}
robot_ip=${3:-127.0.0.1}
days=825
mkdir -p "$dir"
cd "$dir"
umask 077

# The authority.
openssl genpkey -algorithm EC -pkeyopt ec_paramgen_curve:P-256 -out ca.key
openssl req -x509 -new -key ca.key -sha256 -days 3650 -subj "/CN=orsa CA" \
  -addext "basicConstraints=critical,CA:TRUE" \
  -addext "keyUsage=critical,keyCertSign,cRLSign" -out ca.pem

# One key and certificate per process, signed by the authority.
cert() { # NAME SUBJECT_ALT_NAMES
  openssl genpkey -algorithm EC -pkeyopt ec_paramgen_curve:P-256 -out "$1.key"
  openssl req -new -key "$1.key" -subj "/CN=$1" -out "$1.csr"
  printf '%s\n' \
    "basicConstraints=critical,CA:FALSE" \
    "keyUsage=critical,digitalSignature" \
    "extendedKeyUsage=serverAuth,clientAuth" \
    "subjectAltName=$2" > "$1.ext"
  openssl x509 -req -in "$1.csr" -CA ca.pem -CAkey ca.key -CAcreateserial -sha256 \
    -days "$days" -extfile "$1.ext" -out "$1.pem"
  rm -f "$1.csr" "$1.ext"
}
robot_names="DNS:$robot_dns,DNS:localhost,IP:127.0.0.1"
[ "$robot_ip" = 127.0.0.1 ] || robot_names="$robot_names,IP:$robot_ip"
cert robot "$robot_names"
cert executive "DNS:executive"
cert teleop "DNS:teleop"
chmod 644 ca.pem robot.pem executive.pem teleop.pem
echo "certificates in $dir:"
ls -l ca.pem ca.key robot.pem robot.key executive.pem executive.key teleop.pem teleop.key

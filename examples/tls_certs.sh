#!/bin/sh
# A certificate authority and a router certificate for Zenoh's TLS (docs/deployment-tls.md), with openssl:
#
#   sh examples/tls_certs.sh DIR ADDRESS [ADDRESS...]
#
# DIR gets ca.pem (copy it to every host), ca-key.pem (keep it off the network), router.pem and
# router-key.pem (the router host's only). ADDRESS: every IP address or host name that nodes dial the
# router by; a client refuses a router whose certificate does not name the address it dialled. A CA
# already in DIR is reused, so a second router gets a certificate from the same CA.
set -eu
if [ $# -lt 2 ]; then
    echo "usage: $0 DIR ADDRESS [ADDRESS...]" >&2
    exit 2
fi
dir=$1
shift
names=""
for address in "$@"; do
    case "$address" in
        *:*) kind=IP ;;            # IPv6
        *[!0-9.]*) kind=DNS ;;     # a host name
        *) kind=IP ;;              # IPv4
    esac
    names="${names:+$names,}$kind:$address"
done
mkdir -p "$dir"
cd "$dir"
umask 077  # private keys readable by their owner only
if [ ! -f ca.pem ] || [ ! -f ca-key.pem ]; then
    openssl genpkey -algorithm EC -pkeyopt ec_paramgen_curve:P-256 -out ca-key.pem
    openssl req -x509 -new -key ca-key.pem -sha256 -days 825 -subj "/CN=zenroid CA" -out ca.pem \
        -addext "keyUsage=critical,keyCertSign,cRLSign"
fi
openssl genpkey -algorithm EC -pkeyopt ec_paramgen_curve:P-256 -out router-key.pem
openssl req -new -key router-key.pem -subj "/CN=zenroid router" -out router.csr
printf 'subjectAltName=%s\nbasicConstraints=critical,CA:FALSE\nkeyUsage=critical,digitalSignature\nextendedKeyUsage=serverAuth\n' \
    "$names" > router.ext
openssl x509 -req -in router.csr -CA ca.pem -CAkey ca-key.pem -CAcreateserial -sha256 -days 825 \
    -extfile router.ext -out router.pem 2>/dev/null
rm -f router.csr router.ext
chmod 644 ca.pem router.pem
openssl verify -CAfile ca.pem router.pem
echo "router certificate for $names in $dir"

#!/usr/bin/env bash
# Makes what DDS Security needs for saccade's processes: a certificate
# authority, one identity (certificate + private key) per participant, and the
# governance and permissions documents signed by the CA.
#
#   scripts/make-security.sh DIR [NAME ...]      (default names: head_pc robot_pc)
#
# DIR/ca/ keeps the CA's private key: keep it off the robot. Each DIR/NAME/ is
# what one PC needs, and all it needs: copy it there and run
#   saccade run GRAPH.xml --process NAME --security DIR/NAME
# Run again with more names to add participants; an existing CA is reused, so
# earlier identities stay valid. The governance encrypts discovery, liveliness
# and data on every domain and lets no unauthenticated participant join; the
# permissions let each named participant publish and subscribe every topic.
set -euo pipefail

if [ $# -lt 1 ]; then
  echo "usage: $0 DIR [NAME ...]" >&2
  exit 2
fi
dir=$1
shift
names=("$@")
[ ${#names[@]} -gt 0 ] || names=(head_pc robot_pc)
for n in "${names[@]}"; do
  if ! [[ $n =~ ^[A-Za-z0-9_.-]+$ ]]; then
    echo "$0: participant name '$n': use letters, digits, '_', '.', '-'" >&2
    exit 2
  fi
done
command -v openssl >/dev/null || { echo "$0: openssl is missing (scripts/install-deps.sh installs it)" >&2; exit 1; }

mkdir -p "$dir/ca"
umask 077
days=3650
not_before=$(date -u +%Y-%m-%dT%H:%M:%S)
not_after=$(date -u -d "+$days days" +%Y-%m-%dT%H:%M:%S)

if [ ! -f "$dir/ca/key.pem" ]; then
  openssl genpkey -algorithm EC -pkeyopt ec_paramgen_curve:P-256 -out "$dir/ca/key.pem" 2>/dev/null
  openssl req -x509 -new -key "$dir/ca/key.pem" -sha256 -days "$days" -subj "/O=saccade/CN=saccade CA" \
    -out "$dir/ca/cert.pem"
fi

# Every participant listed so far (this run's and earlier runs') gets a grant.
all_names=()
for n in "${names[@]}"; do all_names+=("$n"); done
for d in "$dir"/*/; do
  n=$(basename "$d")
  [ "$n" = ca ] && continue
  [ -f "$d/cert.pem" ] || continue
  [[ " ${all_names[*]} " == *" $n "* ]] || all_names+=("$n")
done

for n in "${names[@]}"; do
  mkdir -p "$dir/$n"
  if [ ! -f "$dir/$n/key.pem" ]; then
    openssl genpkey -algorithm EC -pkeyopt ec_paramgen_curve:P-256 -out "$dir/$n/key.pem" 2>/dev/null
    openssl req -new -key "$dir/$n/key.pem" -subj "/O=saccade/CN=$n" -out "$dir/$n/request.csr"
    openssl x509 -req -in "$dir/$n/request.csr" -CA "$dir/ca/cert.pem" -CAkey "$dir/ca/key.pem" -CAcreateserial \
      -days "$days" -sha256 -out "$dir/$n/cert.pem" 2>/dev/null
    rm -f "$dir/$n/request.csr"
  fi
done

cat > "$dir/ca/governance.xml" <<XML
<?xml version="1.0" encoding="UTF-8"?>
<dds xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance"
     xsi:noNamespaceSchemaLocation="http://www.omg.org/spec/DDS-Security/20170901/omg_shared_ca_governance.xsd">
  <domain_access_rules>
    <domain_rule>
      <domains><id_range><min>0</min><max>232</max></id_range></domains>
      <allow_unauthenticated_participants>false</allow_unauthenticated_participants>
      <enable_join_access_control>true</enable_join_access_control>
      <discovery_protection_kind>ENCRYPT</discovery_protection_kind>
      <liveliness_protection_kind>ENCRYPT</liveliness_protection_kind>
      <rtps_protection_kind>NONE</rtps_protection_kind>
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
XML

{
  cat <<XML
<?xml version="1.0" encoding="UTF-8"?>
<dds xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance"
     xsi:noNamespaceSchemaLocation="http://www.omg.org/spec/DDS-Security/20170901/omg_shared_ca_permissions.xsd">
  <permissions>
XML
  for n in "${all_names[@]}"; do
    cat <<XML
    <grant name="$n">
      <subject_name>CN=$n,O=saccade</subject_name>
      <validity><not_before>$not_before</not_before><not_after>$not_after</not_after></validity>
      <allow_rule>
        <domains><id_range><min>0</min><max>232</max></id_range></domains>
        <publish><topics><topic>*</topic></topics></publish>
        <subscribe><topics><topic>*</topic></topics></subscribe>
      </allow_rule>
      <default>DENY</default>
    </grant>
XML
  done
  cat <<XML
  </permissions>
</dds>
XML
} > "$dir/ca/permissions.xml"

for doc in governance permissions; do
  openssl smime -sign -in "$dir/ca/$doc.xml" -text -out "$dir/ca/$doc.p7s" \
    -signer "$dir/ca/cert.pem" -inkey "$dir/ca/key.pem"
done

for n in "${all_names[@]}"; do
  cp "$dir/ca/cert.pem" "$dir/$n/ca.pem"
  cp "$dir/ca/governance.p7s" "$dir/ca/permissions.p7s" "$dir/$n/"
done
echo "make-security: CA in $dir/ca; participants: ${all_names[*]} (each: ca.pem cert.pem key.pem governance.p7s permissions.p7s)"

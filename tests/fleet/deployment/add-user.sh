#!/bin/sh
# A broker user for a robot or a master control (docs/fleet-deployment.md): a new random
# password, added to Mosquitto's password file and written to the credentials file that
# the robot's [fleet] table names (one line user:password, owner-only).
#   usage: sh add-user.sh PASSWORD_FILE USER CREDENTIALS_FILE
# A robot's USER is its serial number: the ACL's patterns give it only its own topics.
set -eu
passwords=$1 user=$2 credentials=$3
# A topic level (fleet/topics.py), and no ':', which both the password file and the
# credentials file use to end the user name.
case $user in
    '' | *[!A-Za-z0-9._-]*)
        echo "add-user.sh: $user: letters, digits and ._- only" >&2
        exit 2 ;;
esac
# 32 random bytes in hex: nothing to guess, and no ':' or newline to break either file.
password=$(openssl rand -hex 32)
umask 077
printf '%s:%s\n' "$user" "$password" > "$credentials"
# mosquitto_passwd -c would empty a password file that has other users in it.
[ -f "$passwords" ] || : > "$passwords"
# Through a pipe rather than -b: a password on a command line is visible in ps (printf
# is the shell's own, so it never runs as a process).
printf '%s\n%s\n' "$password" "$password" | mosquitto_passwd "$passwords" "$user" >/dev/null

# Start a throw-away PostgreSQL cluster on loopback for the test suite.
# Installs Debian's postgresql package when no server binaries are present.
PGPORT="${PGPORT:-55432}"
PGROOT=""

_pg_bin() {
    ls -d /usr/lib/postgresql/*/bin 2>/dev/null | sort -V | tail -n 1
}

start_postgres() {
    local bin
    bin="$(_pg_bin)"
    if [ -z "$bin" ]; then
        echo "installing PostgreSQL from Debian packages" >&2
        export DEBIAN_FRONTEND=noninteractive
        apt-get update -qq >/dev/null
        apt-get install -y -qq postgresql >/dev/null
        bin="$(_pg_bin)"
    fi
    PGROOT="$(mktemp -d /tmp/causalsplat-pg.XXXXXX)"
    local as_user=()
    if [ "$(id -u)" = "0" ]; then
        id postgres >/dev/null 2>&1 || useradd --system --home "$PGROOT" postgres
        chown postgres "$PGROOT"
        as_user=(runuser -u postgres --)
    fi
    "${as_user[@]}" "$bin/initdb" -D "$PGROOT/data" -A trust -U postgres >/dev/null
    "${as_user[@]}" "$bin/pg_ctl" -D "$PGROOT/data" -l "$PGROOT/server.log" -w \
        -o "-p $PGPORT -k $PGROOT -c listen_addresses=127.0.0.1 -c fsync=off" start >/dev/null
    export PGPORT PGROOT
    PG_AS_USER="${as_user[*]}"
    PG_BIN="$bin"
    echo "PostgreSQL $("$bin/postgres" --version | awk '{print $3}') on 127.0.0.1:$PGPORT" >&2
}

stop_postgres() {
    if [ -n "$PGROOT" ] && [ -d "$PGROOT/data" ]; then
        $PG_AS_USER "$PG_BIN/pg_ctl" -D "$PGROOT/data" -m immediate stop >/dev/null 2>&1 || true
        rm -rf "$PGROOT"
    fi
}
